"""Tests, by part: shared/ (portable core), device/ (firmware), desktop/, tools/; support/ holds helpers."""
