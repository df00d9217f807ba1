"""The one-line messages' sentence start (core.errors.capitalised), used by every layer."""

from hypothesis import given, strategies as st

from core.errors import capitalised


@given(st.text(max_size=40))
def test_only_the_first_letter_changes_and_it_becomes_a_capital(text):
    out = capitalised(text)
    rest = text[1:]
    assert out.endswith(rest)  # a reason written to follow other words keeps its case
    assert out[:len(out) - len(rest)] == text[:1].upper()  # 'ß' begins a sentence as 'SS'


def test_a_message_begun_in_lower_case_reads_as_a_sentence():
    assert capitalised("hands off the handle: the force sensor takes its zero") == (
        "Hands off the handle: the force sensor takes its zero")
    assert capitalised("") == ""
