"""Built-in models (each registers itself with the study runner)."""
