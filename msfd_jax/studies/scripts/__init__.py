"""Scripts that write the recorded validation and accuracy numbers (each names its command)."""
