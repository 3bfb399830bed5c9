"""Fuzzy engine: fuzzy numbers, transformation methods, retransformation, influence."""
