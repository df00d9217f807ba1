"""Fake of `quanser.common`: the base exception of Quanser's Python API."""

from __future__ import annotations


class GenericError(Exception):
    """As in the real package: carries the (negative) Quanser error code; `str()` is the number."""

    def __init__(self, error_code: int) -> None:
        self.error_code = error_code

    def __str__(self) -> str:
        return str(self.error_code)

    def get_error_message(self, locale=None, buffer_size=-1) -> str:
        """The runtime's text for the code (the real one needs the native runtime)."""
        from quanser.hardware import fake_error_text

        return fake_error_text(self.error_code)
