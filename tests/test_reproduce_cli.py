"""``msfd reproduce``: refuses unknown figures; ``--quick --only KEY`` writes its report.

The run shares its compiled program with tests/test_reproduction.py (the quick Fig. 13-14 on
the coarse mesh) when both run in one session.
"""

import json
import re

from msfd_jax import cli


def strict_json(text: str):
    """Strict JSON (tests/test_cli.py): a bare NaN or Infinity is refused."""

    def refuse(constant: str):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_unknown_figure_is_refused_with_the_known_keys(capsys, tmp_path):
    code = cli.main(["reproduce", "--quick", "--only", "fig99", "--results", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == cli.EXIT_USAGE
    assert "fig99" in err and "fig10" in err and "fig23_24" in err
    assert not (tmp_path / "reproduce.md").exists()


def test_quick_only_one_figure(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the quick defaults are relative to the working directory
    code = cli.main(["reproduce", "--quick", "--only", "fig13_14", "--no-cache", "--no-progress"])
    out = capsys.readouterr().out
    assert code == cli.EXIT_OK, out
    base = tmp_path / "reproduce-quick"
    assert (base / "figures" / "fig13.png").exists() and (base / "figures" / "fig14.png").exists()
    data = strict_json((base / "reproduce.json").read_text())
    assert [f["key"] for f in data["figures"]] == ["fig13_14"] and data["quick"]
    report = (base / "reproduce.md").read_text()
    assert "--quick --only fig13_14" in report
    assert not re.search(r"\bnan\b", report, re.IGNORECASE)
    assert not (tmp_path / "docs").exists()  # a quick run never writes the committed figures
