"""run_pipeline / plan_run on fake stages: provenance-based up-to-date detection and failures."""

import os
import time

import pytest
import yaml
from fake_stage import FAKE_ENTRY

from legplan import interrupts
from legplan.artefacts import open_artefact, read_provenance, read_summary
from legplan.pipeline import load_pipeline, plan_run, run_pipeline


def run(path, out, jobs=2, **kwargs):
    return run_pipeline(load_pipeline(path), out, entry=FAKE_ENTRY, jobs=jobs, **kwargs)


def statuses(result):
    return {r.name: r.status for r in result.results}


def test_first_run_runs_everything_then_nothing(tmp_path, chain):
    out = tmp_path / "out"
    first = run(chain, out, jobs=2)
    assert statuses(first) == {"a": "ran", "b": "ran", "c": "ran", "d": "ran"}
    assert first.ok
    ran_a = next(r for r in first.results if r.name == "a")
    assert ran_a.line() == f"a (no output yet) {ran_a.seconds:.1f} s"   # why it ran, not "a: missing ..."
    with open_artefact(out / "c.h5") as f:
        assert read_summary(f)["inputs"] == (2.0, "")
    assert [d.run for d in plan_run(load_pipeline(chain), out)] == [False] * 4
    later = time.time() + 100
    for path in (tmp_path / "src.txt", out / "a.h5"):   # touched, content unchanged
        os.utime(path, (later, later))
    assert statuses(run(chain, out, jobs=1)) == dict.fromkeys("abcd", "up_to_date")


def test_changed_input_content_reruns_stage_and_dependants(tmp_path, chain):
    out = tmp_path / "out"
    run(chain, out)
    (tmp_path / "src.txt").write_text("source v2\n")
    decisions = {d.name: d for d in plan_run(load_pipeline(chain), out)}
    assert decisions["a"].run and decisions["a"].reason.startswith("input changed")
    assert decisions["b"].reason == "upstream stage 'a' will run"
    assert not decisions["d"].run
    assert statuses(run(chain, out)) == {"a": "ran", "b": "ran", "c": "ran", "d": "up_to_date"}


def test_changed_param_reruns(tmp_path, chain):
    out = tmp_path / "out"
    run(chain, out)
    data = yaml.safe_load(chain.read_text())
    data["stages"][0]["params"]["value"] = 3.0
    chain.write_text(yaml.safe_dump(data, sort_keys=False))
    decision = plan_run(load_pipeline(chain), out)[0]
    assert decision.run and decision.reason.startswith("params changed")
    assert "--value 2.0" in decision.reason
    assert statuses(run(chain, out))["a"] == "ran"
    with open_artefact(out / "a.h5") as f:
        assert read_summary(f)["value"] == (3.0, "m")


def test_deleted_output_reruns_only_what_needs_it(tmp_path, chain, monkeypatch):
    """With a pinned creation time the rewritten b.h5 is byte-identical, so c stays up to date."""
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    out = tmp_path / "out"
    run(chain, out)
    (out / "sub" / "b.h5").unlink()
    decisions = {d.name: (d.run, d.reason) for d in plan_run(load_pipeline(chain), out)}
    assert decisions["b"] == (True, "no output yet")
    assert decisions["a"] == (False, "up to date")
    result = statuses(run(chain, out))
    assert result == {"a": "up_to_date", "b": "ran", "c": "up_to_date", "d": "up_to_date"}
    assert statuses(run(chain, out, force=True)) == dict.fromkeys("abcd", "ran")


def test_failing_stage_skips_dependants_and_reports_reason(tmp_path, write_pipeline):
    path = write_pipeline({"stages": [
        {"name": "a", "command": ["fake", "make"], "output": "a.h5", "params": {"fail": True}},
        {"name": "b", "command": ["fake", "make", "{stages.a.output}"], "output": "b.h5"},
        {"name": "c", "command": ["fake", "make"], "output": "c.h5"},
    ]})
    result = run(path, tmp_path / "out")
    by_name = {r.name: r for r in result.results}
    assert not result.ok and [r.name for r in result.failed] == ["a"]
    assert by_name["a"].returncode == 2
    assert "fake failure: the planner blew up" in by_name["a"].reason
    assert by_name["b"].status == "skipped" and "upstream stage 'a' failed" in by_name["b"].reason
    assert by_name["c"].status == "ran"
    assert not (tmp_path / "out" / "b.h5").exists()


def test_items_failed_stage_lets_dependants_run(tmp_path, write_pipeline):
    path = write_pipeline({"stages": [
        {"name": "a", "command": ["fake", "make"], "output": "a.h5", "params": {"items-failed": True}},
        {"name": "b", "command": ["fake", "make", "{stages.a.output}"], "output": "b.h5"},
    ]})
    result = run(path, tmp_path / "out")
    assert statuses(result) == {"a": "items_failed", "b": "ran"}
    assert result.ok


def test_stage_leaving_stale_output_counts_as_failed(tmp_path, write_pipeline):
    """A command that exits 0 but does not rewrite its output must not pass as up to date."""
    out = tmp_path / "out"
    spec = {"stages": [{"name": "a", "command": ["fake", "make"], "output": "a.h5"}]}
    path = write_pipeline(spec)
    run(path, out)
    spec["stages"][0]["params"] = {"fail": True}
    write_pipeline(spec)
    result = run(path, out)
    assert result.failed[0].name == "a" and result.failed[0].returncode == 2
    assert (out / "a.h5").exists()


def test_an_interrupt_starts_nothing_more_and_names_what_was_published(tmp_path, chain):
    """The interrupt arrives (here: raised by the progress callback) once stage 'a' has settled:
    no later stage runs, and the interrupted message names a's output, not "nothing published"."""
    out = tmp_path / "out"

    def interrupt(result):
        if result.name == "a":
            raise KeyboardInterrupt

    with interrupts.handle_interrupts():
        with pytest.raises(KeyboardInterrupt):
            run(chain, out, jobs=1, on_result=interrupt)
        assert interrupts.interrupted_message() == f"stopped after publishing {out / 'a.h5'}"
    assert sorted(p.name for p in out.iterdir()) == ["a.h5", "logs"]


def test_a_stage_shared_through_a_variable_runs_once_for_two_pipelines(tmp_path, write_pipeline):
    """Pipeline `second` writes its stage `a` to `first`'s output directory (`{shared}/a.h5`) with
    the same command: after `first` ran, `second` finds `a` up to date and runs only `b`."""
    (tmp_path / "src.txt").write_text("x\n")
    stage_a = {"name": "a", "command": ["fake", "make", "{pipeline_dir}/src.txt"], "inputs": ["{pipeline_dir}/src.txt"],
               "output": "a.h5"}
    first = write_pipeline({"name": "first", "stages": [stage_a]}, "first.yaml")
    second = write_pipeline({"name": "second", "vars": {"shared": "{out}/../first"}, "stages": [
        {**stage_a, "output": "{shared}/a.h5"},
        {"name": "b", "command": ["fake", "make", "{stages.a.output}"], "inputs": ["{stages.a.output}"],
         "output": "b.h5"}]}, "second.yaml")
    assert statuses(run(first, tmp_path / "out" / "first")) == {"a": "ran"}
    result = run(second, tmp_path / "out" / "second")
    assert statuses(result) == {"a": "up_to_date", "b": "ran"}
    assert (tmp_path / "out" / "second" / "b.h5").is_file() and not (tmp_path / "out" / "second" / "a.h5").exists()


def test_an_output_may_start_with_a_variable_only(tmp_path, write_pipeline):
    from legplan.errors import SpecError

    for output, message in (("x/{shared}.h5", "only at its start"), ("{stages.a.output}/b.h5", "not a stage")):
        path = write_pipeline({"name": "p", "vars": {"shared": "{out}/../o"}, "stages": [
            {"name": "a", "command": ["fake", "make"], "output": "a.h5"},
            {"name": "b", "command": ["fake", "make"], "output": output}]})
        with pytest.raises(SpecError, match=message):
            load_pipeline(path)


def test_an_environment_reaches_every_stage_and_changes_no_up_to_date_decision(tmp_path, chain, monkeypatch):
    monkeypatch.delenv("LEGPLAN_SCHEDULER", raising=False)
    out = tmp_path / "out"
    assert run(chain, out, environment={"LEGPLAN_SCHEDULER": "tcp://127.0.0.1:8786"}).ok
    for name in ("a.h5", "sub/b.h5", "c.h5", "d.h5"):
        with open_artefact(out / name) as f:
            assert read_provenance(f)["params"]["scheduler"] == "tcp://127.0.0.1:8786"
    assert statuses(run(chain, out)) == dict.fromkeys("abcd", "up_to_date")  # not part of the provenance
