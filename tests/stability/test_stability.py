"""The numerical stability suite (raytrace/commands/stability/), case by case at both lane widths: the very rows
`python -m raytrace stability` prints, each held to its verdict. A known limit passes only while its error
stays within the stated limit, so it cannot silently get worse."""
from functools import cache

import pytest

from raytrace.commands import stability

@cache
def env(lanes):
    return stability.Env(lanes)


@pytest.mark.parametrize("lanes", [1, 8], ids=["lanes1", "lanes8"])
@pytest.mark.parametrize("case", stability.CASES, ids=[case.__name__ for case in stability.CASES])
def test_case(case, lanes):
    rows = stability.run_case(env(lanes), case)
    assert rows
    for row in rows:
        expected = "skipped" if row.skipped else "known limit" if row.known_limit else "pass"
        assert row.verdict == expected, stability.format_row(row)
