"""The one error a user's input can raise."""


class InvalidInput(ValueError):
    """Bad user input, raised before anything is stepped. The message is one line
    naming the field and what it may be."""
