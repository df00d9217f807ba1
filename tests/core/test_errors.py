"""The one-line messages' sentence start (core.errors.capitalised), used by every layer."""

from hypothesis import given, strategies as st

from core.errors import capitalised


@given(st.text(max_size=40))
def test_only_the_first_letter_changes_and_it_becomes_a_capital(text):
    out = capitalised(text)
    assert out[1:] == text[1:]  # a reason written to follow other words keeps its case
    assert out[:1] == text[:1].upper()


def test_a_message_begun_in_lower_case_reads_as_a_sentence():
    assert capitalised("hands off the handle: the force sensor takes its zero") == (
        "Hands off the handle: the force sensor takes its zero")
    assert capitalised("") == ""
