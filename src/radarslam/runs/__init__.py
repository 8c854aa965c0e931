"""What each command does end to end: a recording, a dataset, the radar alone; the progress line."""
