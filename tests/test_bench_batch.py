"""benchmarks/bench_batch.py: the report's arithmetic (the processes themselves are timed by running it)."""

from __future__ import annotations

from benchmarks.bench_batch import gap, markdown, process_cpu, summarise


def row(name, single, batch, peer, mine, theirs):
    rec = {"valid": mine is not None, "status": "optimal" if mine is not None else "infeasible",
           "objective": mine, "objective_on_n": mine}  # fmt: skip
    return {"set": "paper", "name": name, "single": {"seconds": single, "cpu": single / 2, **rec},
            "batch": {"seconds": batch, "cpu": batch / 2, **rec},
            "peer": {"seconds": peer, "cpu": peer / 2, "objective": theirs},
            "gap": gap(mine, theirs)}  # fmt: skip


def test_medians_ratios_and_the_agreement_count():
    rows = [row("a", 2.0, 1.0, 4.0, 1.0, 1.0), row("b", 4.0, 2.0, 2.0, 1.002, 1.0), row("c", 9.0, 8.0, 6.0, None, None)]
    s = summarise(rows)
    assert s["median"] == {"single": 4.0, "batch": 2.0, "peer": 4.0}
    assert s["median_cpu"] == {"single": 2.0, "batch": 1.0, "peer": 2.0}
    assert (s["both"], s["agree"], s["single_ok"], s["peer_ok"]) == (2, 1, 2, 2)  # b is 0.2 % worse
    assert gap(0.999, 1.0) < 0 < gap(1.002, 1.0) and gap(None, 1.0) is None
    meta = {"sets": "paper", "machine": "m", "commit": "c", "load_before": "1", "load_after": "1",
            "batch_seconds": 11.0, "single_total": 15.0, "peer_total": 12.0, "summary": s}  # fmt: skip
    text = markdown(rows, meta)
    assert "| `roundabout solve` per scenario | 4.00 | 1.00 | 2.00 | 1.00 | <= 1.0 |" in text
    assert "| batch (one process) | 2.00 | 0.50 | 1.00 | 0.50 | <= 0.5 |" in text
    assert "in 1 of them (50 %" in text and "failed (infeasible)" in text


def test_the_cpu_of_a_running_process_is_read_from_proc():
    import os

    assert process_cpu(os.getpid()) > 0.0
