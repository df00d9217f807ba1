"""The one exception family of `app`: the clinic's workflow without a screen.

Messages name the file or record concerned, say what is wrong and what to do,
because the window shows them to a therapist as they are.
"""

from __future__ import annotations


class AppError(Exception):
    """Base of every error raised by `app`."""


class TrialFileError(AppError):
    """A trial file cannot be read: missing, damaged, or not a trial file this console reads."""

    def __init__(self, path: object, problem: str, advice: str) -> None:
        self.path = path
        self.problem = problem
        self.advice = advice
        super().__init__(f"trial file {path}: {problem}. {advice}")


class DataDirError(AppError):
    """The data folder (or one of its sub-folders) cannot be created or written."""


class SettingsError(AppError):
    """The settings file cannot be written."""


class RegistryURLError(AppError):
    """The registry URL file cannot be trusted (not private to its user) or names no
    registry this console can use; the message says what is wrong and what to do."""


class RegistryError(AppError):
    """The patient/session/trial registry refused an operation or cannot be used."""


class RegistryUnreachable(RegistryError):
    """The registry's server cannot be reached (the network or the server is down): a
    station records on its own until it returns (issue 32)."""


class RegistryLoginRefused(RegistryUnreachable):
    """The registry's server answered but refused this login (its password, its database,
    its rights): not the network. A station records on its own meanwhile all the same."""


class PatientNotFound(RegistryError, LookupError):
    """No patient has the code asked for."""


class TrialNotFound(RegistryError, LookupError):
    """No trial has the id asked for."""


class DuplicateNumberError(RegistryError):
    """A session or trial number is not the next one: already taken, or it would leave a
    gap (numbers have no gaps and no repeats: app.records.registry.numbering)."""


class SchemaError(RegistryError):
    """The registry's database was written by a newer console, or is not a registry."""


class SessionNotFound(RegistryError, LookupError):
    """A patient has no session with the number asked for."""


class InvalidRecordError(RegistryError, ValueError):
    """A value given for a patient, session or trial is missing or out of range."""
