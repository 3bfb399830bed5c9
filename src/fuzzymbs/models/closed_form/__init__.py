"""Closed-form models (registered for demos and tests)."""
