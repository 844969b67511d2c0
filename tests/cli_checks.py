"""Checks shared by the CLI tests."""


def one_error(capsys, status: int, *words: str) -> str:
    """Exit status 2 and exactly one ``predgait: error:`` line holding every word; the line."""
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert len(lines) == 1 and lines[0].startswith("predgait: error: "), err
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]
