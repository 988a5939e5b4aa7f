"""The malformed-program corpus: each file names its expected errors in ``# expect:`` lines.

Every case must produce exactly the expected ``line:col: message`` errors (syntax, counts,
ranges, structure, and, through the dry run, unreachable targets and infeasible paths), and
``parolkit check`` must exit non-zero for it.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from parolkit.script import parse_file
from parolkit.script.dryrun import dry_run

CORPUS = sorted((Path(__file__).resolve().parents[1] / "data" / "rbt" / "malformed").glob("*.rbt"))
_EXPECT = re.compile(r"^# expect: (\d+):(\d+): (.+)$", re.M)


def test_the_corpus_has_at_least_25_cases():
    assert len(CORPUS) >= 25


def _errors(path: Path):
    result = parse_file(path)
    if not result.ok:
        return list(result.errors), "parse"
    return list(dry_run(result.program).errors), "dry run"


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.stem)
def test_malformed_program_gives_the_expected_line_col_errors(path):
    expected = [(int(a), int(b), msg) for a, b, msg in _EXPECT.findall(path.read_text())]
    assert expected, f"{path.name} has no '# expect:' line"
    errors, stage = _errors(path)
    got = [(e.line, e.col, e.message) for e in errors]
    assert [g[:2] for g in got] == [e[:2] for e in expected], f"{stage}: {got}"
    for (line, col, message), (_, _, want) in zip(got, expected):
        assert want in message, f"{path.name}:{line}:{col}: {message!r} does not contain {want!r}"
    for e in errors:
        assert e.format().startswith(f"{path}:{e.line}:{e.col}: error: ")


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.stem)
def test_check_command_exits_non_zero_and_prints_the_location(path, capsys):
    from parolkit.cli import main

    rc = main(["check", str(path)])
    out = capsys.readouterr()
    assert rc == 1
    first = _EXPECT.search(path.read_text())
    assert f"{path}:{first.group(1)}:{first.group(2)}: error:" in out.out + out.err
