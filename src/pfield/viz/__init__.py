"""Visualisation: matplotlib plots (headless PNG/GIF) and viewers."""
