"""The first hour with the tool (issue 30): list options read one way, outputs
checked before any work, unknown options suggest the closest, an empty batch is
an error without a lock, the console and reports say what they mean (no nan,
plurals, units, fit verdict with its limits) and batch trends pair modes by
frequency and MAC."""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ema_pipeline import io
from ema_pipeline.acquisition import modal_frf
from ema_pipeline.cli import build_parser, main
from ema_pipeline.cli.parser import MODES_CSV_HELP
from ema_pipeline.data import DOF, FRFSet, ModalParameters
from ema_pipeline.pipeline.batch import LOCK_NAME
from ema_pipeline.report import BatchReportInput, render_batch_html
from ema_pipeline.report.trends import pair_modes
from ema_pipeline.report.wording import FIT_LIMITS, fit_grade, fit_verdict, plural


def _parse(argv: list[str]):
    return build_parser().parse_args(argv)


# ------------------------------------------------------------------ list options
@pytest.mark.parametrize("flag", ["--expect"])
def test_list_option_takes_commas_or_separate_arguments(flag: str) -> None:
    base = ["identify", "a.uff", "--out", "o"]
    assert _parse([*base, flag, "17,69"]).expect == (17.0, 69.0)
    assert _parse([*base, flag, "17", "69"]).expect == (17.0, 69.0)
    assert _parse([*base, flag, "17", "69", "--band", "1", "90"]).band == [1.0, 90.0]
    args = _parse(["simulate", "--out", "x.uff", "--fd-hz", "18", "112", "--zeta-pct", "0.5,1"])
    assert (args.fd_hz, args.zeta_pct) == ((18.0, 112.0), (0.5, 1.0))


@pytest.mark.parametrize("text", ["17 69", "1 7", "17,,69", "17, 69", "1e"])
@pytest.mark.parametrize("flag", ["--expect", "--fd-hz", "--zeta-pct"])
def test_list_option_in_one_string_is_never_glued(flag: str, text: str, capsys) -> None:
    """``--expect "17 69"`` used to be 1769 Hz and ``"1 7"`` 17 Hz: now exit 2."""
    argv = (["identify", "a.uff", "--out", "o"] if flag == "--expect"
            else ["simulate", "--out", "x.uff"]) + [flag, text]
    with pytest.raises(SystemExit) as exc:
        _parse(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}" in err and repr(text) in err and "1769" not in err


def test_unknown_option_or_command_suggests_the_closest(capsys) -> None:
    for argv, hint in [
        (["identify", "a.uff", "--out", "o", "--bnad", "1", "2"], "did you mean --band?"),
        (["batch", "d", "--out", "o", "--foce"], "did you mean --force?"),
        (["run", "--no-figrues", "--jsno"], "--no-figrues -> --no-figures, --jsno -> --json"),
        (["idnetify", "a.uff"], "did you mean identify?"),
    ]:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert hint in err and err.count("\n") == 1, err


def test_identify_help_lists_every_modes_csv_column(tmp_path: Path, capsys) -> None:
    """Against the columns ``identify`` really writes (with --expect)."""
    frf, _ = _frf([30.0, 70.0], np.arange(0.0, 150.0, 0.25))
    path = tmp_path / "two.h5"
    io.write_frf(frf, path, "h5")
    assert main(["identify", str(path), "--out", str(tmp_path / "o"), "--quiet",
                 "--expect", "30", "70"]) == 0
    table = pd.read_csv(tmp_path / "o" / "two_modes.csv")
    written = table.columns
    # both modes answer a guess: selected as expected
    assert list(table["found_by"]) == ["expected", "expected"]
    assert list(table["selection"]) == ["expected", "expected"]
    with pytest.raises(SystemExit):
        main(["identify", "--help"])
    text = capsys.readouterr().out
    assert MODES_CSV_HELP.strip() in text
    listed = set(re.findall(r"^  ([a-z_]+)(?:, ([a-z_]+))?", MODES_CSV_HELP, re.M))
    names = {n for pair in listed for n in pair if n}
    assert set(written) <= names, set(written) - names


# ------------------------------------------------------------------ outputs first
def test_out_naming_a_file_is_exit_2_before_any_identification(
    tmp_path: Path, example_dir: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    import ema_pipeline.pipeline.single as single

    def never(*args, **kwargs):
        raise AssertionError("identification started")

    monkeypatch.setattr(single, "identify_file", never)
    monkeypatch.setattr(single, "identify", never)
    taken = tmp_path / "taken.csv"
    taken.write_text("x")
    uff = str(example_dir / "genuine.uff")
    cases = [
        (["identify", uff, "--out", str(taken)], "--out names an existing file"),
        (["identify", uff, "--out", str(taken / "sub")], f"{taken} is a file"),
        (["batch", str(example_dir), "--out", str(taken)], "--out names an existing file"),
        (["fe", str(taken), "--out", str(taken)], "--out names an existing file"),
        (["run", "--raw", str(example_dir), "--results", str(taken)],
         "--results names an existing file"),
        (["simulate", "--out", str(tmp_path)], "--out names an existing folder"),
        (["simulate", "--out", str(tmp_path / "s.uff"), "--time-records", str(taken / "t.uff")],
         f"{taken} is a file"),
    ]
    for argv, problem in cases:
        start = time.perf_counter()
        assert main(argv) == 2, argv
        assert time.perf_counter() - start < 2.0  # checked first, not after the work
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and problem in err, err
        assert "Error:" not in err and "Traceback" not in err
    assert taken.read_text() == "x"
    assert not (tmp_path / "s.uff").exists()


# ------------------------------------------------------------------ batch of nothing
def test_batch_of_an_empty_folder_or_a_file_is_exit_2_without_a_lock(
    tmp_path: Path, capsys
) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "notes.txt").write_text("no FRF here")
    out = tmp_path / "out"
    assert main(["batch", str(empty), "--out", str(out)]) == 2
    assert "no FRF files" in capsys.readouterr().err
    assert not out.exists() and not list(tmp_path.rglob(LOCK_NAME))
    out.mkdir()  # an existing OUT gets no lock either
    assert main(["batch", str(empty / "notes.txt"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "a file, not a folder" in err and err.count("\n") == 1
    assert list(out.iterdir()) == []


# ------------------------------------------------------------------ wording
def test_plural_and_fit_verdict_limits() -> None:
    assert [plural(n, "mode") for n in (0, 1, 2)] == ["0 modes", "1 mode", "2 modes"]
    good, fair = FIT_LIMITS.good_pct / 100, FIT_LIMITS.fair_pct / 100
    assert fit_grade(good) == "good" and fit_grade(good + 1e-6) == "fair"
    assert fit_grade(fair) == "fair" and fit_grade(fair + 1e-6) == "poor"
    # the verdict states the limit it was judged against
    assert f"{FIT_LIMITS.good_pct:g} %" in fit_verdict(0.117 if good < 0.117 else good + 0.01)


def test_run_console_has_no_nan_and_proper_plurals(example_study_uff_no_figures: Path) -> None:
    console = (example_study_uff_no_figures.parent / "console.txt").read_text()
    assert "local added mass" in console and "exact" in console  # the summary is there
    assert not re.search(r"\bnan\b", console, re.I), [
        line for line in console.splitlines() if re.search(r"\bnan\b", line, re.I)]
    assert not re.search(r"\b1 modes\b", console)
    exact = [line for line in console.splitlines() if re.match(r"\s+\w+\s+exact\s", line)]
    assert exact and all("delta_k = not fitted" in line for line in exact)


def test_study_report_fit_verdict_and_mpd(example_study_uff_no_figures: Path) -> None:
    html = (example_study_uff_no_figures / "report.html").read_text()
    assert "MPD: not provided" not in html and "MPD (°)</th>" in html
    assert ">why doubtful</th>" in html  # the rule that fired, beside doubtful
    assert "fit: good if the mean error" in html
    cells = re.findall(r"<td[^>]*>(\d+\.\d\d) \((good|fair|poor)\)</td>", html)
    assert len(cells) == 3  # one per configuration, the grade beside the number
    for pct, grade in cells:
        assert fit_grade(float(pct) / 100) == grade
    if any(grade != "good" for _, grade in cells):
        assert "Complete: every configuration identified" not in html


def test_run_keeping_earlier_results_says_why_on_its_last_line(
    tmp_path: Path, example_dir: Path, capsys
) -> None:
    import shutil

    shutil.copytree(example_dir, tmp_path / "raw")
    toml = tmp_path / "raw" / "experiment.toml"
    toml.write_text(toml.read_text().replace("n_modes = 4", "n_modes = 6"))
    res = tmp_path / "res"
    res.mkdir()
    (res / "report.md").write_text("earlier")
    assert main(["run", "--raw", str(tmp_path / "raw"), "--results", str(res), "--quiet",
                 "--no-figures"]) == 1
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "kept unchanged because" in last and "the FE stage needs 6" in last
    assert (res / "report.md").read_text() == "earlier"


# ------------------------------------------------------------------ batch trends
def _frf(fn_hz: list[float], f: np.ndarray, modes_of: list[int] | None = None,
         ) -> tuple[FRFSet, ModalParameters]:
    """Noise-free receptances of a string-like system at 4 responses: mode k has
    the shape sin(k pi x) (``modes_of`` picks k per frequency; default 1, 2, ...)."""
    truth = ModalParameters(fn_hz=fn_hz, zeta=[0.01] * len(fn_hz))
    ks = modes_of or list(range(1, len(fn_hz) + 1))
    x = np.array([0.13, 0.37, 0.58, 0.81])
    phi = np.stack([np.sin(k * np.pi * x) for k in ks], axis=1)
    H = modal_frf(f, truth, phi, np.array([np.sin(np.pi * np.array(ks) * 0.9)]),
                  quantity="receptance")
    frf = FRFSet(freq_hz=f, H=H, quantity="receptance",
                 response_dofs=tuple(DOF(k + 1) for k in range(4)), reference_dofs=(DOF(9),))
    return frf, truth


def test_pair_modes_by_frequency_and_mac() -> None:
    # a file lacking the 70 Hz mode: its 131 Hz mode is the third, not the second
    table = pair_modes([[30, 70, 130], [30.5, 131], [29, 68, 126]])
    np.testing.assert_array_equal(np.isnan(table), [[0, 0, 0], [0, 1, 0], [0, 0, 0]])
    np.testing.assert_allclose(table[1, [0, 2]], [30.5, 131])
    # two modes close in frequency: the shapes decide (orthogonal unit vectors)
    e = np.eye(3)
    shapes = [e[:, :2], e[:, [1]]]  # file 2 has only the shape of 52 Hz, found at 50.5 Hz
    table = pair_modes([[50, 52], [50.5]], shapes)
    np.testing.assert_allclose(table[1], [np.nan, 50.5])
    assert np.isnan(pair_modes([[50, 52], [50.5]])[1, 1])  # by frequency alone: 50 Hz


def _html_tables(html: str) -> list[pd.DataFrame]:
    """The report's tables as frames of numbers (NaN for empty cells), by regex:
    the page is ours and regular (no lxml needed)."""
    def text(cell: str) -> str:
        return re.sub(r"<[^>]+>", "", cell).strip()

    frames = []
    for table in re.findall(r"<table.*?</table>", html, re.S):
        head = [text(h) for h in re.findall(r"<th[^>]*>(.*?)</th>", table, re.S)]
        rows = [[text(c) for c in re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)]
                for row in re.findall(r"<tr>(.*?)</tr>", table.split("<tbody>")[-1], re.S)]
        frame = pd.DataFrame([r for r in rows if len(r) == len(head)], columns=head)
        for col in frame.columns:
            try:
                frame[col] = pd.to_numeric(frame[col].replace("", np.nan))
            except ValueError:
                pass
        frames.append(frame)
    return frames


def test_batch_report_pairs_a_missing_mode(tmp_path: Path) -> None:
    """A batch whose second file lacks the 70 Hz mode: its 130 Hz mode is
    reported with the others' 130 Hz mode (by index it would be 'mode 2')."""
    f = np.arange(0.0, 200.0, 0.25)
    raw = tmp_path / "raw"
    raw.mkdir()
    specs = {"a": ([30.0, 70.0, 130.0], None), "b": ([30.3, 131.0], [1, 3]),
             "c": ([29.7, 69.0, 128.0], None)}
    for name, (fn, ks) in specs.items():
        io.write_frf(_frf(fn, f, ks)[0], raw / f"{name}.h5", "h5")
    out = tmp_path / "out"
    assert main(["batch", str(raw), "--out", str(out), "--workers", "1", "--quiet",
                 "--report", "--no-figures"]) == 0
    summary = pd.read_csv(out / "summary.csv")
    assert "fit_error_pct" in summary and "fit_error" not in summary
    assert (summary["fit_error_pct"] < 1).all()  # noise-free: per cent, below 1 %
    html = (out / "report.html").read_text()
    parts = [t for t in _html_tables(html) if "file" in t.columns and "status" in t.columns
             or "f3 (Hz)" in t.columns]  # the per-file table, maybe split into parts
    files = pd.concat(parts, axis=1)
    files = files.loc[:, ~files.columns.duplicated()]
    np.testing.assert_allclose(files["f1 (Hz)"], [30, 30.3, 29.7], rtol=1e-3)
    np.testing.assert_allclose(files["f3 (Hz)"], [130, 131, 128], rtol=1e-3)
    assert files["f2 (Hz)"].isna().tolist() == [False, True, False]
    assert "3 files" in html and "paired across the files by frequency" in html


def test_batch_figure_says_missing_and_outliers_in_words() -> None:
    summary = pd.DataFrame({
        "file": ["a", "b", "c"], "status": ["ok"] * 3, "configuration": [""] * 3,
        "frequencies_hz": ["30;70;130", "30.3;131", "29.7;69;128"],
        "fit_error_pct": [1.0, 2.0, 30.0],
    })
    html = render_batch_html(BatchReportInput(title="t", folder="in", summary=summary,
                                              failures=pd.DataFrame()))
    assert "missing in 1 file" in html and "1 outliers" not in html
    assert ">poor<" in html and ">good<" in html


def test_the_exit_statuses_are_those_the_readme_names() -> None:
    """The README's exit statuses, their meanings and the constants it names are the
    command line's (``cli.support``, their one home); an input error is 2 and a
    runtime failure 1 under those names."""
    from ema_pipeline.cli import support

    readme = " ".join((Path(__file__).resolve().parents[1] / "README.md").read_text().split())
    said = re.search(r"Exit status: (.*?) \((`EXIT_\w+`(?:, `EXIT_\w+`)*) of "
                     r"`ema_pipeline.cli.support`\)", readme)
    assert said is not None
    statuses = [item.split(" ", 1) for item in said.group(1).split(", ")]
    names = re.findall(r"`(EXIT_\w+)`", said.group(2))
    assert {int(code): meaning for code, meaning in statuses} == support.EXIT_STATUSES
    assert [getattr(support, name) for name in names] == [int(code) for code, _ in statuses]
    assert (support.EXIT_OK, support.EXIT_INPUT, support.EXIT_RUNTIME) == (0, 2, 1)
