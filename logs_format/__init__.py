"""logs_format package."""
