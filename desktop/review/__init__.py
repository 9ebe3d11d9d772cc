"""Flight review: replay a flight log through the board's code, and plot it."""
