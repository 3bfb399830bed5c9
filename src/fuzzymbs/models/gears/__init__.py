"""MUBOCO-PR pseudo-rigid contact-based spur-gear pair."""
