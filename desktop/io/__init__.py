"""Readers and writers of flight data: flight CSV, board logs, rocket files, OpenRocket exports."""
