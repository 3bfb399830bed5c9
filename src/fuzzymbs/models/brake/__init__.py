"""Elastic multibody disc brake."""
