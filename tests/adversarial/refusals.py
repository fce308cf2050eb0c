"""What every refusal of bad input looks like to a user: exit status 2 and one line on stderr, no
traceback."""

from __future__ import annotations


def refused(result: tuple[int, str, str], *fragments: str) -> str:
    """The one line of a refusal (``result``: status, stdout, stderr), checked to hold
    ``fragments``."""
    code, _, err = result
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, err
    return err.strip()
