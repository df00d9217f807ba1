"""Fake of Quanser's Python API package (`quanser`), for tests without the Quanser SDK."""
