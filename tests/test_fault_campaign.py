"""The fault campaign (``rotlab stress --faults``) in CI: a fixed seed, two inputs per category
(hostile config values and bytes, special files, hostile output paths, bad options, Ctrl-C at a
random moment, load formulas that fail, random tops and centres of mass, vectors of the wrong
length, huge literals, reversed sweep ranges), each against the real CLI in its own process.  Every outcome must keep the
promises: exit 0/1/2/130, one line and no traceback on failure, no hang, no temporary file left,
inputs and special files untouched, an existing recording never replaced by a failed run, every
recording readable."""

from __future__ import annotations

from rotlab.stress.faults import CATEGORIES, run_campaign, table


def test_fault_campaign_breaks_no_promise():
    verdicts = run_campaign(seed=0, count=2)
    assert {v.category for v in verdicts} == set(CATEGORIES)
    broken = [v for v in verdicts if v.broken]
    assert not broken, "\n".join(f"{v.category}: {v.name}: {v.outcome} — {v.detail}" for v in broken) + "\n" + table(verdicts)


def test_a_broken_promise_is_reported(tmp_path, monkeypatch):
    """The classifier sees a traceback and a clobbered input (a campaign that cannot fail is no check)."""
    from rotlab.stress import faults

    crash = faults.Attempt("probe", "traceback", ["run", "in.toml"], {"in.toml": b"x"})
    monkeypatch.setattr(faults, "_execute", lambda attempt, d, limit: (1, "Traceback (most recent call last):\nBoom\n"))
    assert faults.run_attempt(crash).outcome == "traceback"

    def clobber(attempt, d, limit):
        (d / "in.toml").write_bytes(b"overwritten")
        return 2, "rotlab: error: something\n"

    monkeypatch.setattr(faults, "_execute", clobber)
    assert faults.run_attempt(crash).outcome == "input clobbered"

    import random

    failing = next(faults.failing_loads(random.Random(0), 1))  # a load that cannot succeed, "succeeding"
    monkeypatch.setattr(faults, "_execute", lambda attempt, d, limit: (0, ""))
    assert faults.run_attempt(failing).outcome == "wrong outcome"
