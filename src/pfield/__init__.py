"""pfield: potential-field motion planning and shared control."""

__version__ = "0.1.0"
