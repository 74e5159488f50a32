"""Learning log-linear weights from Python: closed-form maximum-likelihood answers
where pseudo-likelihood equals likelihood, a chain CRF whose learned model decodes
its training labels, and errors."""

import math

import numpy as np
import pytest

import pgm


def coin(labels):
    fs = pgm.FeatureSet("coin")
    bias = fs.add_template("bias", ["heads"])
    data = []
    for y in labels:
        m = pgm.LogLinearModel(fs, [2])
        m.add_clique(bias, [0], [[0.0], [1.0]])  # feature "heads" is 1 in state 1
        data.append((m, [y]))
    return fs, data


def test_a_biased_coin_learns_its_log_odds():
    fs, data = coin([1, 1, 1, 0])
    r = pgm.learn(fs, data, prior_variance=math.inf)
    assert r["converged"]
    assert r["weights"]["bias.heads"] == pytest.approx(math.log(3), abs=1e-5)
    assert r["weight_vector"].tolist() == pytest.approx([math.log(3)], abs=1e-5)
    assert fs.names == ["bias.heads"]


def test_independent_variables_learn_their_log_frequencies():
    # Unary cliques only: pseudo-likelihood is the likelihood, and the MLE of a
    # one-hot (state indicator) template is log-frequency up to a constant.
    rng = np.random.default_rng(4)
    fs = pgm.FeatureSet("dice")
    t = fs.add_template("face", ["1", "2", "3"])
    labels = rng.choice(3, size=300, p=[0.2, 0.3, 0.5])
    data = []
    for y in labels:
        m = pgm.LogLinearModel(fs, [3])
        m.add_clique(t, [0], np.eye(3))
        data.append((m, [int(y)]))
    w = pgm.learn(fs, data, prior_variance=math.inf)["weight_vector"]
    freq = np.bincount(labels, minlength=3) / len(labels)
    np.testing.assert_allclose(w - w.mean(), np.log(freq) - np.log(freq).mean(), atol=1e-4)


def test_a_chain_crf_decodes_its_training_labels():
    # Observations x in {0, 1} copied into labels with noise-free agreement; a
    # unary "agree" feature and a pairwise "same" feature.
    fs = pgm.FeatureSet("chain")
    unary = fs.add_template("obs", ["agree"])
    pair = fs.add_template("pair", ["same"])
    rng = np.random.default_rng(9)
    data, models = [], []
    for _ in range(30):
        n = 8
        y = np.repeat(rng.integers(0, 2, size=2), n // 2)  # two runs
        m = pgm.LogLinearModel(fs, [2] * n)
        for i in range(n):
            m.add_clique(unary, [i], [[1.0 if s == y[i] else 0.0] for s in range(2)])
        for i in range(n - 1):
            m.add_clique(pair, [i, i + 1], [[[1.0], [0.0]], [[0.0], [1.0]]])
        data.append((m, y.tolist()))
        models.append((m, y))
    r = pgm.learn(fs, data, prior_variance=10.0)
    assert r["weights"]["obs.agree"] > 1.0
    for m, y in models[:5]:
        g = m.to_factor_graph(r["weight_vector"])
        assert g.map()["assignment"].tolist() == y.tolist()


def test_the_three_objectives_agree_where_they_must():
    # A chain whose pairwise "same" feature couples the labels: pseudo-likelihood and
    # maximum likelihood learn different weights; on a chain Bethe is maximum likelihood.
    fs = pgm.FeatureSet("chain")
    unary = fs.add_template("obs", ["agree"])
    pair = fs.add_template("pair", ["same"])
    rng = np.random.default_rng(5)
    data = []
    for _ in range(40):
        n = 6
        x = rng.integers(0, 2, size=n)
        y = np.where(rng.random(n) < 0.8, x, 1 - x)
        m = pgm.LogLinearModel(fs, [2] * n)
        for i in range(n):
            m.add_clique(unary, [i], [[1.0 if s == x[i] else 0.0] for s in range(2)])
        for i in range(n - 1):
            m.add_clique(pair, [i, i + 1], [[[1.0], [0.0]], [[0.0], [1.0]]])
        data.append((m, y.tolist()))
    results = {o: pgm.learn(fs, data, prior_variance=10.0, objective=o) for o in ["pl", "ml", "bethe"]}
    for o, r in results.items():
        assert r["converged"] and r["objective_name"] == o
    np.testing.assert_allclose(results["bethe"]["weight_vector"], results["ml"]["weight_vector"], atol=1e-6)
    assert abs(results["ml"]["weights"]["pair.same"] - results["pl"]["weights"]["pair.same"]) > 1e-3
    # The maximum-likelihood objective by brute force (64 assignments per chain): the
    # learner's value at its optimum, which pseudo-likelihood's weights do not beat.
    states = np.array(np.meshgrid(*[[0, 1]] * 6, indexing="ij")).reshape(6, -1).T

    def ml_value(w):
        total = float(np.dot(w, w)) / (2 * 10.0)
        for m, y in data:
            g = m.to_factor_graph(w)
            scores = np.array([g.log_score(x.tolist()) for x in states])
            top = scores.max()
            total += top + math.log(np.exp(scores - top).sum()) - g.log_score(y)
        return total

    best = ml_value(results["ml"]["weight_vector"])
    assert best == pytest.approx(results["ml"]["objective"], rel=1e-9)
    assert best < ml_value(results["pl"]["weight_vector"])


def test_maximum_likelihood_refuses_a_loop():
    fs = pgm.FeatureSet("loop")
    pair = fs.add_template("pair", ["same"])
    m = pgm.LogLinearModel(fs, [2, 2, 2])
    for a, b in [(0, 1), (1, 2), (0, 2)]:
        m.add_clique(pair, [a, b], [[[1.0], [0.0]], [[0.0], [1.0]]])
    with pytest.raises(pgm.PgmError, match=r"instance 0: its factor graph has a cycle"):
        pgm.learn(fs, [(m, [0, 0, 1])], objective="ml")
    assert pgm.learn(fs, [(m, [0, 0, 1])], objective="bethe")["converged"]
    with pytest.raises(pgm.PgmError, match=r"objective: \"exact\": expected pl"):
        pgm.learn(fs, [(m, [0, 0, 1])], objective="exact")


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda fs, m: m.add_clique(0, [0], [[1.0, 2.0], [0.0, 1.0]]), r"features: 2 features per joint state, but template 0 has 1"),
        (lambda fs, m: m.add_clique(0, [0], [1.0, 0.0]), r"features: 1 axes for a scope of 1 variables"),
        (lambda fs, m: m.add_clique(5, [0], [[1.0], [0.0]]), r"template = 5: the feature set has 1 templates"),
        (lambda fs, m: pgm.learn(fs, [(m, [3])]), r"."),
        (lambda fs, m: pgm.learn(fs, [(m, [1])], prior_variance=-1.0), r"prior variance"),
        (lambda fs, m: pgm.learn(fs, [m]), r"instances\[0\]: .*\(expected \(LogLinearModel, labels\)\)"),
        (lambda fs, m: pgm.learn(pgm.FeatureSet("other"), [(m, [1])]), r"instances\[0\]: its model was made from another feature set"),
        (lambda fs, m: fs.add_template("late", ["x"]), r"add every template first"),
    ],
)
def test_learning_errors(call, message):
    fs = pgm.FeatureSet("coin")
    fs.add_template("bias", ["heads"])
    m = pgm.LogLinearModel(fs, [2])
    with pytest.raises(pgm.PgmError, match=message):
        call(fs, m)
