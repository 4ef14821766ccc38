"""Issue 23: result attributes are named as the metric functions; the old names are deprecated read-only aliases.

(1) Every old name (``local``, ``global_``, ``sup_local``, ``sup_global``) of every result class warns
``"<Class>.<old> is deprecated: use <Class>.<new>"`` at the caller's line and returns the new attribute itself;
it is no dataclass field. (2) An audit, a certificate, calibrations, a sample plan and a privacy curve run with
fairaudit's own deprecation warnings turned into errors: the library no longer reads the old names.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd
import pytest

import fairaudit as fa
from fairaudit._deprecated import renamed
from fairaudit.calibrate import calibrate
from fairaudit.certify import Observed
from fairaudit.experiments.analysis import PaperDesignPoint, PointResult
from fairaudit.experiments.paper_design import DesignPoint
from fairaudit.report import audit_dict, calibration_dict, certificate_dict, plan_dict, render

FAIRNESS = {"local": "local_fairness", "global_": "global_fairness"}
ALL = {**FAIRNESS, "sup_local": "sup_local_fairness", "sup_global": "sup_global_fairness"}
RENAMED = [
    (Observed, ALL),
    (fa.FairnessIntervals, ALL),
    (fa.WorstModel, FAIRNESS),
    (fa.WorstUtility, FAIRNESS),
    (DesignPoint, FAIRNESS),
    (PaperDesignPoint, FAIRNESS),
    (PointResult, FAIRNESS),
]
OWN = ".* is deprecated: use "  # the message of fairaudit's renamed attributes


def _instance(cls: type) -> object:
    """An instance whose every field holds its own sentinel (the aliases only forward)."""
    return cls(**{f.name: object() for f in dataclasses.fields(cls)})


@pytest.mark.parametrize(("cls", "names"), RENAMED, ids=[c.__name__ for c, _ in RENAMED])
def test_old_names_warn_and_return_the_new_attribute(cls, names):
    obj = _instance(cls)
    fields = {f.name for f in dataclasses.fields(cls)}
    assert set(names.values()) <= fields and not set(names) & fields  # the aliases are no fields
    for old, new in names.items():
        message = f"{cls.__name__}.{old} is deprecated: use {cls.__name__}.{new}"
        with pytest.warns(DeprecationWarning) as seen:
            value = getattr(obj, old)
        assert value is getattr(obj, new)
        assert [str(w.message) for w in seen] == [message]
        assert isinstance(cls.__dict__[old], renamed) and getattr(cls, old) is cls.__dict__[old]
        with pytest.raises(AttributeError), warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            object.__setattr__(obj, old, None)  # read-only, even past the frozen dataclass's __setattr__
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        repr(obj)
        dataclasses.replace(obj)  # (fields only: no alias is read)


@pytest.mark.parametrize("slots", [False, True])
def test_the_alias_works_on_frozen_dataclasses_with_or_without_slots(slots):
    @dataclasses.dataclass(frozen=True, eq=False, kw_only=True, slots=slots)
    class Result:
        global_fairness: float
        global_ = renamed[float]("global_fairness")

    r = Result(global_fairness=1.5)
    assert [f.name for f in dataclasses.fields(Result)] == ["global_fairness"]
    assert hasattr(Result, "__slots__") == slots
    with pytest.warns(DeprecationWarning, match=r"^Result\.global_ is deprecated: use Result\.global_fairness$"):
        assert r.global_ == 1.5
    with pytest.raises(AttributeError):
        object.__setattr__(r, "global_", 2.0)
    with pytest.raises(AttributeError):
        object.__delattr__(r, "global_")


def test_the_warning_points_at_the_callers_line():
    law = fa.Law([[[0.5, 0.5], [0.2, 0.8]]], ["x"], ["a", "b"], ["yes", "no"])
    w = fa.worst_utility(law)
    with pytest.warns(
        DeprecationWarning, match=r"^WorstUtility\.global_ is deprecated: use WorstUtility\.global_fairness$"
    ) as seen:
        assert w.global_ is w.global_fairness
    assert seen[0].filename == __file__


def test_real_results_alias_their_own_attributes():
    c = fa.certify("examples/llm_hiring/gpt35.toml")
    o = c.observed
    with pytest.warns(
        DeprecationWarning, match=r"^Observed\.sup_global is deprecated: use Observed\.sup_global_fairness$"
    ):
        assert o.sup_global is o.sup_global_fairness
    with pytest.warns(DeprecationWarning, match=r"^WorstModel\.local is deprecated: use WorstModel\.local_fairness$"):
        assert c.black_box.local is c.black_box.local_fairness


def _records(n: int = 400, seed: int = 5) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    race = rng.choice(["A", "B", "C"], n)
    site = rng.choice(["north", "south"], n)
    y = (rng.random(n) < np.where(race == "A", 0.6, 0.4)).astype(int)
    return pd.DataFrame({"race": race, "site": site, "hired": y})


@pytest.fixture
def own_deprecations_are_errors():
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=OWN, category=DeprecationWarning)
        yield


@pytest.mark.usefixtures("own_deprecations_are_errors")
def test_audit_reads_no_old_name():
    for method in ("clopper-pearson", "bayes"):
        r = fa.audit(_records(), sensitive=["race"], outcome="hired", context=["site"], confidence=0.9, method=method)
        r.to_frame(), r.by_context, r.by_group, r.gaps_on_g, r.population, r.small_cell
        d = audit_dict(r)
        for fmt in ("text", "json", "markdown", "html"):
            render(d, "audit", fmt)


@pytest.mark.usefixtures("own_deprecations_are_errors")
def test_certify_reads_no_old_name():
    c = fa.certify("examples/llm_hiring/gpt35.toml")
    d = certificate_dict(c)
    for fmt in ("text", "json", "markdown", "html"):
        render(d, "certify", fmt)
    assert d["observed"]["global"]["value"] == c.observed.global_fairness.value  # the JSON keys do not change


@pytest.mark.usefixtures("own_deprecations_are_errors")
def test_calibrate_plan_and_curve_read_no_old_name():
    labels = ["a", "b"]
    kernel = fa.Kernel([[[0.9, 0.1], [0.5, 0.5]], [[0.2, 0.8], [0.1, 0.9]]], ["x0", "x1"], labels, ["y", "n"])
    pop = fa.Population([[0.4, 0.1], [0.1, 0.4]], ["x0", "x1"], labels)
    g = fa.indicator("y", ["y", "n"])
    runs = [
        calibrate(0.3, kernel=kernel, utility=g, population=pop),  # white box on L
        calibrate(1.5, kind="global", method="black_box", utility=g, groups=labels, population=pop),  # worst model
        calibrate(0.5, kind="global", method="black_box", groups=2),
        fa.calibrate_randomized_response(0.5, 2),
    ]
    for c in runs:
        for fmt in ("text", "json", "markdown", "html"):
            render(calibration_dict(c), "calibrate", fmt)
    plans = [fa.plan(1.0, kind=kind, datasets=40, seed=1) for kind in ("local", "global")]
    render(plan_dict(plans), "plan", "text")
    family = fa.randomized_response_family(labels)
    curve = fa.privacy_curve(family=family, epsilons=[0.5, 1.0], kernel=kernel, utility=g, population=pop)
    assert len(curve.to_frame()) == 2
    fa.worst_utility(fa.compose(kernel, fa.randomized_response(labels, 1.0)), lower=0.2).global_fairness
