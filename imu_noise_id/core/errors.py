"""Error classes for bad input. Adapters turn these into one clear message and exit code 2."""


class InputError(ValueError):
    """Input the user can fix (a file, a topic, a parameter): the message says what and what to do."""
