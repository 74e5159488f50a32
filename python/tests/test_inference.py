"""The Python package against brute force, against pgmpy's exact inference, and against
its own error contract.

Brute force enumerates every assignment of small random models (numpy only). pgmpy
(from PyPI) is the independent reference the field uses: variable elimination for
marginals and MAP. Belief propagation is exact on trees, so trees are compared for
both; on loopy graphs only TRW-S answers with a certificate (gap 0), and where it has
one its assignment must be pgmpy's MAP.
"""

import itertools
import math
import os
import pathlib

import numpy as np
import pytest

import pgm

SCHEDULES = ["flooding", "sequential", "residual"]


def random_model(rng, n, edges, max_card=3, zeros=False):
    """Cardinalities, and factors (scope, potential table) with a unary per variable."""
    cards = [int(rng.integers(2, max_card + 1)) for _ in range(n)]
    factors = []
    for v in range(n):
        factors.append(([v], rng.uniform(0.2, 2.0, size=cards[v])))
    for a, b in edges:
        table = rng.uniform(0.1, 3.0, size=(cards[a], cards[b]))
        if zeros:
            table[rng.integers(cards[a]), rng.integers(cards[b])] = 0.0
        factors.append(([a, b], table))
    return cards, factors


def random_tree(rng, n):
    return [(int(rng.integers(v)), v) for v in range(1, n)]


def random_loopy(rng, n):
    edges = random_tree(rng, n)
    present = set(edges)
    # A tree plus up to three more edges (a triangle at most on three variables).
    while len(edges) < min(n + 2, n * (n - 1) // 2):
        a, b = sorted(int(x) for x in rng.choice(n, size=2, replace=False))
        if (a, b) not in present:
            present.add((a, b))
            edges.append((a, b))
    return edges


def build(cards, factors):
    g = pgm.FactorGraph(cards)
    for scope, table in factors:
        g.add_factor(scope, table)
    return g


def brute_force(cards, factors):
    """Exact marginals, the MAP assignment and its log-score, by enumeration."""
    best, best_score = None, -math.inf
    marginals = [np.zeros(k) for k in cards]
    total = 0.0
    for x in itertools.product(*(range(k) for k in cards)):
        p = 1.0
        for scope, table in factors:
            p *= table[tuple(x[v] for v in scope)]
        total += p
        for v, s in enumerate(x):
            marginals[v][s] += p
        score = math.log(p) if p > 0 else -math.inf
        if score > best_score:
            best, best_score = x, score
    return [m / total for m in marginals], list(best), best_score


@pytest.mark.parametrize("seed", range(20))
def test_trees_match_brute_force_under_every_schedule(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 7))
    cards, factors = random_model(rng, n, random_tree(rng, n), zeros=seed % 2 == 1)
    exact, best, best_score = brute_force(cards, factors)
    g = build(cards, factors)
    for schedule in SCHEDULES:
        for damping in (0.0, 0.5):
            m = g.marginals(schedule=schedule, damping=damping, max_iterations=5000)
            assert m["converged"], (schedule, damping)
            for got, want in zip(m["marginals"], exact):
                np.testing.assert_allclose(got, want, atol=1e-6)
            r = g.map(schedule=schedule, damping=damping, max_iterations=5000)
            assert r["converged"]
            assert r["assignment"].dtype == np.int64
            assert r["log_score"] == pytest.approx(best_score, abs=1e-9)
            assert g.log_score(r["assignment"].tolist()) == pytest.approx(best_score, abs=1e-9)
    t = g.trws()
    assert t["gap"] == pytest.approx(0.0, abs=1e-7)
    assert t["log_score"] == pytest.approx(best_score, abs=1e-9)
    assert t["bound"] >= best_score - 1e-9


@pytest.mark.parametrize("seed", range(20))
def test_trws_bound_holds_on_loopy_graphs(seed):
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(3, 7))
    cards, factors = random_model(rng, n, random_loopy(rng, n))
    _, _, best_score = brute_force(cards, factors)
    t = build(cards, factors).trws(max_iterations=2000)
    assert t["bound"] >= best_score - 1e-9
    assert t["log_score"] <= best_score + 1e-9
    if t["gap"] <= 1e-9:
        assert t["log_score"] == pytest.approx(best_score, abs=1e-9)


def test_tables_in_any_memory_layout_and_in_log_space():
    rng = np.random.default_rng(7)
    table = rng.uniform(0.5, 2.0, size=(3, 2))
    a = pgm.FactorGraph([3, 2])
    a.add_factor([0, 1], table)
    b = pgm.FactorGraph([3, 2])
    b.add_factor([0, 1], np.asfortranarray(table))
    c = pgm.FactorGraph([2, 3])
    c.add_factor([1, 0], table)  # the same table over swapped scope order
    d = pgm.FactorGraph([3, 2])
    d.add_factor([0, 1], np.log(table), log=True)
    want = a.marginals()["marginals"]
    for g in (b, d):
        for got, ref in zip(g.marginals()["marginals"], want):
            np.testing.assert_allclose(got, ref, atol=1e-12)
    swapped = c.marginals()["marginals"]
    np.testing.assert_allclose(swapped[1], want[0], atol=1e-12)
    np.testing.assert_allclose(swapped[0], want[1], atol=1e-12)


def test_tables_from_lists_and_other_dtypes():
    want = pgm.FactorGraph([2])
    want.add_factor([0], np.array([1.0, 3.0]))
    for table in ([1, 3], [1.0, 3.0], np.array([1, 3]), np.array([1, 3], dtype=np.float32)):
        g = pgm.FactorGraph([2])
        g.add_factor([0], table)
        np.testing.assert_allclose(g.marginals()["marginals"][0], want.marginals()["marginals"][0], atol=1e-12)


def test_marginals_warn_when_their_modes_do_not_fit_together():
    # A feasible loopy model (an even cycle, "not equal" tables) whose marginals are
    # uniform: each variable's most probable state is 0, which no table allows.
    ne = np.array([[0.0, 1.0], [1.0, 0.0]])
    g = pgm.FactorGraph([2] * 6)
    for v in range(6):
        g.add_factor([v, (v + 1) % 6], ne)
    with pytest.warns(UserWarning, match=r"probability 0"):
        m = g.marginals()
    assert m["log_score"] == -math.inf
    assert g.map()["log_score"] == 0.0


def test_uai_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    cards, factors = random_model(rng, 5, random_loopy(rng, 5))
    g = build(cards, factors)
    path = tmp_path / "model.uai"
    path.write_text(g.to_uai())
    h = pgm.FactorGraph.from_uai(path)
    assert h.cardinalities == cards
    assert h.num_factors == g.num_factors
    for x in itertools.islice(itertools.product(*(range(k) for k in cards)), 50):
        assert h.log_score(list(x)) == pytest.approx(g.log_score(list(x)), abs=1e-9)


def test_evidence_file_conditions_the_model(tmp_path):
    rng = np.random.default_rng(11)
    cards, factors = random_model(rng, 4, random_tree(rng, 4))
    (tmp_path / "m.uai").write_text(build(cards, factors).to_uai())
    (tmp_path / "m.evid").write_text("1 2 1\n")
    g = pgm.FactorGraph.from_uai(tmp_path / "m.uai", evidence=tmp_path / "m.evid")
    m = g.marginals()["marginals"]
    np.testing.assert_allclose(m[2], np.eye(cards[2])[1], atol=1e-12)
    with pytest.raises(pgm.PgmError, match=r"m\.evid: sample 1, but the file holds 1 evidence sample "):
        pgm.FactorGraph.from_uai(tmp_path / "m.uai", evidence=tmp_path / "m.evid", sample=1)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: pgm.FactorGraph([2, 0]), r"cardinalit"),
        (lambda: pgm.FactorGraph([2, 3]).add_factor([0, 1], np.ones((2, 2))), r"axis 1 has 2 entries, but variable 1 has cardinality 3"),
        (lambda: pgm.FactorGraph([2, 3]).add_factor([0, 5], np.ones((2, 3))), r"scope\[1\] = 5: the graph has 2 variables"),
        (lambda: pgm.FactorGraph([2]).add_factor([0], np.ones((2, 1))), r"2 axes for a scope of 1 variables"),
        (lambda: pgm.FactorGraph([2, 2]).add_factor([0, 1], np.array([[1.0, -1.0], [1.0, 1.0]])), r"table\[0, 1\] = -1: potentials must be finite and >= 0"),
        (lambda: pgm.FactorGraph([2]).add_factor([0], np.array([0.0, np.nan]), log=True), r"table\[1\] = NaN: log-potentials"),
        (lambda: pgm.FactorGraph([2]).map(schedule="random"), r"schedule = random: one of flooding, sequential, residual"),
        (lambda: pgm.FactorGraph([2]).marginals(damping=1.0), r"damping = 1\.0: a number in \[0, 1\)"),
        (lambda: pgm.FactorGraph([2]).trws(max_iterations=0), r"max_iterations"),
        (lambda: pgm.FactorGraph([2, 2]).log_score([0]), r"."),
        (lambda: pgm.FactorGraph([2, -1]), r"cardinalities\[1\] = -1: expected a whole number >= 0"),
        (lambda: pgm.FactorGraph([2]).add_factor([-1], np.ones(2)), r"scope\[0\] = -1: expected a whole number >= 0"),
        (lambda: pgm.FactorGraph([2]).map(max_iterations=-1), r"max_iterations = -1: expected a whole number >= 0"),
        (lambda: pgm.FactorGraph([2]).add_factor([0], "two"), r"table: .*expected an array of numbers"),
        (lambda: pgm.FactorGraph.from_uai("/nonexistent/model.uai"), r"/nonexistent/model\.uai"),
    ],
)
def test_errors_are_pgm_errors_naming_the_value(call, message):
    with pytest.raises(pgm.PgmError, match=message) as info:
        call()
    assert isinstance(info.value, ValueError)


def test_a_model_with_no_positive_assignment_is_refused_by_every_method():
    # Hard "not equal" on a triangle with two colours: every table is satisfiable alone,
    # the model is not (the ../shared case uai-infeasible-loop, built here).
    ne = np.array([[0.0, 1.0], [1.0, 0.0]])
    g = pgm.FactorGraph([2, 2, 2])
    for scope in ([0, 1], [1, 2], [0, 2]):
        g.add_factor(scope, ne)
    for method in (g.map, g.marginals, g.trws):
        with pytest.raises(pgm.PgmError, match=r"no assignment has positive probability \(Z = 0\)"):
            method()


def shared_case(name):
    root = pathlib.Path(__file__).resolve().parents[2] / ".." / "shared" / "cases"
    path = root / name
    if not path.exists():
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} is missing, and CI always has ../shared")
        pytest.skip(f"{path} not found (../shared is not beside this checkout)")
    return path


def test_the_shared_infeasible_case_gives_the_command_line_message():
    path = shared_case("uai-infeasible-loop/triangle_2col.uai")
    g = pgm.FactorGraph.from_uai(path)
    with pytest.raises(pgm.PgmError) as info:
        g.trws()
    text = str(info.value)
    assert text.startswith(f"{path}: TRW-S: no assignment has positive probability (Z = 0)")
    assert "factor 2 (scope [0, 2]) is 0 at states [0, 0]" in text


# --- pgmpy, the field's reference implementation ------------------------------------

def need_pgmpy():
    """pgmpy, or a skip outside CI (CI installs it and must run these tests)."""
    if os.environ.get("CI") == "true":
        import pgmpy  # noqa: F401  (an ImportError fails the test in CI)
    else:
        pytest.importorskip("pgmpy")


def pgmpy_model(cards, factors):
    need_pgmpy()
    from pgmpy.factors.discrete import DiscreteFactor

    try:
        from pgmpy.models import DiscreteMarkovNetwork as Network
    except ImportError:  # pgmpy < 1.0
        from pgmpy.models import MarkovNetwork as Network
    names = [f"x{v}" for v in range(len(cards))]
    net = Network()
    net.add_nodes_from(names)
    for scope, _ in factors:
        if len(scope) == 2:
            net.add_edge(names[scope[0]], names[scope[1]])
    pf = [DiscreteFactor([names[v] for v in scope], [cards[v] for v in scope], table.ravel()) for scope, table in factors]
    net.add_factors(*pf)
    return net, names


@pytest.mark.parametrize("seed", range(15))
def test_marginals_and_map_equal_pgmpy_on_trees(seed):
    need_pgmpy()
    from pgmpy.inference import VariableElimination

    rng = np.random.default_rng(500 + seed)
    n = int(rng.integers(2, 8))
    cards, factors = random_model(rng, n, random_tree(rng, n), max_card=4)
    net, names = pgmpy_model(cards, factors)
    ve = VariableElimination(net)
    g = build(cards, factors)
    m = g.marginals()["marginals"]
    for v, name in enumerate(names):
        q = ve.query([name], show_progress=False)  # unnormalised on a Markov network
        np.testing.assert_allclose(m[v], q.values / q.values.sum(), atol=1e-8)
    want = ve.map_query(names, show_progress=False)
    got = g.map()["assignment"].tolist()
    assert got == [int(want[name]) for name in names]


@pytest.mark.parametrize("seed", range(15))
def test_certified_trws_map_equals_pgmpy_on_loopy_graphs(seed):
    need_pgmpy()
    from pgmpy.inference import VariableElimination

    rng = np.random.default_rng(900 + seed)
    n = int(rng.integers(3, 7))
    cards, factors = random_model(rng, n, random_loopy(rng, n))
    net, names = pgmpy_model(cards, factors)
    want = VariableElimination(net).map_query(names, show_progress=False)
    want = [int(want[name]) for name in names]
    g = build(cards, factors)
    t = g.trws(max_iterations=5000)
    _, best, best_score = brute_force(cards, factors)
    assert g.log_score(want) == pytest.approx(best_score, abs=1e-9)  # pgmpy is exact
    if t["gap"] <= 1e-9:
        assert t["log_score"] == pytest.approx(best_score, abs=1e-9)
    else:
        assert t["bound"] >= best_score - 1e-9


def test_the_package_states_its_version():
    import importlib.metadata
    assert pgm.__version__ == importlib.metadata.version("pgm")
    assert pgm.__version__.count(".") >= 2
