"""Fast checks of the bench pieces: prompts files, variants, judge parsing, ids, CLIP setting,
paired statistics, and the CLI's one-line errors."""

from __future__ import annotations

from pathlib import Path

import pytest
from scipy import stats
from typer.testing import CliRunner

from procedura_brep.bench.cases import BenchError, default_prompts, load_cases, parse_variants
from procedura_brep.bench.clip import ENV_CLIP, clip_setting
from procedura_brep.bench.judge import item_id, normalise, parse_scores
from procedura_brep.bench.paired import compare
from procedura_brep.cli import app

ROOT = Path(__file__).resolve().parents[2]


def test_mechbench36_is_36_labelled_one_sentence_prompts():
    pset = load_cases()
    assert pset.name == "MechBench-36 (reconstructed)"
    assert len(pset.cases) == 36 and len({c.id for c in pset.cases}) == 36
    assert sum(c.source == "figure" for c in pset.cases) == 6
    for c in pset.cases:
        assert c.prompt.endswith(".") and c.prompt.count(". ") == 0, c.id  # one sentence


def test_the_prompts_ship_once_inside_the_package():
    """Issue 25.5: a top-level copy of the prompts file was kept equal by a test; there is one."""
    assert default_prompts().is_file() and not (ROOT / "bench").exists()


@pytest.mark.parametrize("body, needle", [
    ('[[case]]\nid = "a"\nprompt = "x"\n[[case]]\nid = "a"\nprompt = "y"\n', "used twice"),
    ('[[case]]\nid = "Bad-Id"\nprompt = "x"\n', "snake_case"),
    ('[[case]]\nid = "a"\nprompt = ""\n', "non-empty"),
    ('[[case]]\nid = "a"\nprompt = "x"\ncpus = 0\n', "outside (0, 64]"),
    ('name = "empty"\n', "no cases"),
    ('[[case]\n', "not valid TOML"),
])
def test_bad_prompts_files_are_one_line_errors(tmp_path, body, needle):
    p = tmp_path / "p.toml"
    p.write_text(body)
    with pytest.raises(BenchError, match=needle.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")
                       .replace("]", r"\]")) as exc:
        load_cases(p)
    assert "\n" not in str(exc.value)


def test_variants_are_checked():
    assert parse_variants("full, one-shot,full") == ("full", "one-shot")
    with pytest.raises(BenchError, match="unknown variant.*bogus.*variants: full, one-shot"):
        parse_variants("full,bogus")


def test_judge_scores_parse_and_map_to_unit_range():
    assert parse_scores('ok {"geometry": 7, "aesthetics": 4, "semantic": 10, "reason": "r"}') == \
        {"geometry": 7.0, "aesthetics": 4.0, "semantic": 10.0}
    assert parse_scores("Geometry: 3\nAesthetics = 5\nsemantic 8/10") == \
        {"geometry": 3.0, "aesthetics": 5.0, "semantic": 8.0}
    with pytest.raises(ValueError, match="no semantic score"):
        parse_scores('{"geometry": 3, "aesthetics": 5}')
    assert [normalise(v) for v in (1, 10, 5.5, 0, 12)] == [0.0, 1.0, 0.5, 0.0, 1.0]


def test_item_ids_are_opaque_and_salted():
    a = item_id("s1", "lamp", "one-shot")
    assert "one-shot" not in a and "lamp" not in a and len(a) == 16
    assert a != item_id("s1", "lamp", "full") and a != item_id("s2", "lamp", "one-shot")


def test_clip_not_computed_without_a_setting(monkeypatch):
    monkeypatch.delenv(ENV_CLIP, raising=False)
    assert clip_setting(None) is None


def test_clip_setting_parses_arch_and_path(monkeypatch, tmp_path):
    w = tmp_path / "clip.pt"
    w.write_bytes(b"x")
    monkeypatch.setenv(ENV_CLIP, f"ViT-L-14@{w}")
    s = clip_setting(None)
    assert (s.arch, s.path, s.source) == ("ViT-L-14", w, ENV_CLIP)
    s = clip_setting(str(w))  # the option wins over the environment; default architecture
    assert (s.arch, s.path, s.source) == ("ViT-B-32", w, "--clip-weights")
    with pytest.raises(BenchError, match="do not exist"):
        clip_setting(str(tmp_path / "missing.pt"))
    with pytest.raises(BenchError, match="architecture before '@' is empty"):
        clip_setting(f"@{w}")


def test_paired_sign_test_and_interval():
    rows = []
    for case, (a, b) in {"c1": (0.9, 0.5), "c2": (0.8, 0.6), "c3": (0.4, 0.7), "c4": (0.6, 0.6),
                         "c5": (0.7, 0.2)}.items():
        rows += [{"case": case, "variant": "full", "overall": a},
                 {"case": case, "variant": "one-shot", "overall": b}]
    res = compare(rows, "full", "one-shot", "overall")
    assert (res["n"], res["wins"], res["losses"], res["ties"]) == (5, 3, 1, 1)
    assert res["sign_p"] == pytest.approx(stats.binomtest(3, 4, 0.5).pvalue)
    diffs = [0.4, 0.2, -0.3, 0.0, 0.5]
    assert res["mean_diff"] == pytest.approx(sum(diffs) / 5)
    ci = stats.t.interval(0.95, 4, loc=sum(diffs) / 5, scale=stats.sem(diffs))
    assert (res["ci_low"], res["ci_high"]) == pytest.approx(ci, abs=1e-6)


def test_cli_bench_usage_errors_are_one_line(tmp_path):
    r = CliRunner().invoke(app, ["bench", "-m", "replay:x", "-o", str(tmp_path / "b"), "--variants", "nope"])
    assert r.exit_code == 2 and "unknown variant(s) nope" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(app, ["bench", "--from", str(tmp_path)])
    assert r.exit_code == 2 and "holds no bench" in r.output
    r = CliRunner().invoke(app, ["bench", "-m", "replay:x", "-o", str(tmp_path / "b"), "--pair", "full"])
    assert r.exit_code == 2 and "write two variant names" in r.output


def test_a_run_that_errors_scores_zero_and_is_retried(tmp_path):
    """A run whose tape is missing ends in an error: recorded, scored as shipping nothing, exit 1,
    and not finished, so the next call tries it again."""
    prompts = tmp_path / "p.toml"
    prompts.write_text('[[case]]\nid = "ghost"\nprompt = "a thing nobody taped"\n')
    tapes = tmp_path / "tapes"
    tapes.mkdir()
    (tapes / "judge.jsonl").write_text("")
    args = ["bench", "--prompts", str(prompts), "-m", f"replay:{tapes}", "-o", str(tmp_path / "b"),
            "--variants", "one-shot", "--no-simulate"]
    for _ in range(2):
        r = CliRunner().invoke(app, args)
        assert r.exit_code == 1, r.output
        assert "1 run(s) ended in an error" in r.output and "ghost/one-shot" in r.output
        assert "0 finished already, 1 to run" in r.output
    import json
    rec = json.loads((tmp_path / "b/runs/ghost/one-shot/bench_run.json").read_text())
    assert rec["status"] == "error" and "does not exist" in rec["error"]
    summary = json.loads((tmp_path / "b/tables/summary.json").read_text())["summary"][0]
    assert (summary["shipped"], summary["overall"], summary["clip"]) == (0, 0.0, None)
