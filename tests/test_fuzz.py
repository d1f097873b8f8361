"""The fuzzer (sphfluid fuzz): broken scenes and bad API calls end cleanly."""
from __future__ import annotations

from collections import Counter

import pytest
from conftest import ROOT
from sphfluid import fuzz
from sphfluid.cli import main

SCENES = ROOT / "scenes"


def test_a_few_hundred_cases_have_no_bad_outcome():
    results = fuzz.fuzz(400, seed=1, folder=SCENES)
    bad = [r for r in results if r.outcome in fuzz.BAD]
    assert not bad, bad[:3]
    counts = Counter((r.kind, r.outcome) for r in results)
    # The cases reach the core, not only the loader's messages.
    assert counts[("scene", "error")] > 50 and counts[("scene", "ran")] > 10
    assert counts[("api", "error")] > 50 and counts[("api", "ran")] > 5


def test_the_cases_are_made_again_from_their_seed():
    a = fuzz.fuzz(6, seed=3, folder=SCENES)
    b = fuzz.fuzz(6, seed=3, folder=SCENES)
    key = [(r.kind, r.index, r.outcome, r.detail.split(".json")[-1]) for r in a]
    assert key == [(r.kind, r.index, r.outcome, r.detail.split(".json")[-1]) for r in b]
    assert fuzz.case_json(2, 3, SCENES) == fuzz.case_json(2, 3, SCENES)


@pytest.mark.parametrize("kind,outcome", [("_raise", "traceback"), ("_abort", "crash"),
                                          ("_hang", "hang"), ("_memory", "memory")])
def test_each_bad_outcome_is_caught(kind, outcome):
    if kind == "_memory" and not fuzz.memory_limited():
        pytest.skip("no memory limit here (AddressSanitizer's build)")
    w = fuzz._Worker(SCENES)
    try:
        r = w.run(kind, 0, 0, timeout=5)
        assert r.outcome == outcome, r
        if outcome != "traceback":  # the worker is gone: a new one carries on
            w.close()
            w = fuzz._Worker(SCENES)
        assert w.run("api", 0, 0, timeout=60).outcome not in fuzz.BAD
    finally:
        w.close()


def test_an_unclear_error_counts_as_bad(monkeypatch):
    def reshape_error(*_):
        raise ValueError("cannot reshape array of size 1 into shape (2)")

    monkeypatch.setattr(fuzz, "_run_api", reshape_error)
    assert fuzz.run_case("api", 0, 0, []).outcome == "traceback"


def test_the_command_prints_its_table(capsys):
    assert main(["fuzz", "--cases", "20", "--seed", "5", "--scenes", str(SCENES)]) == 0
    out = capsys.readouterr().out
    assert "sphfluid fuzz --cases 20 --seed 5" in out and "| traceback (bad) | 0 | 0 |" in out
    assert "bad: 0" in out
    assert main(["fuzz", "--case", "scene:3", "--seed", "5", "--scenes", str(SCENES)]) == 0
    assert "scene case 3 (seed 5): " in capsys.readouterr().out
