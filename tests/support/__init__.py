"""Test helpers: the float reference filter and the software-in-the-loop fakes (sil/)."""
