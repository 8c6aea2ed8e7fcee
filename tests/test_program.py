"""Straight-line programs: derivatives and substitutions equal SymPy's on explicit forms."""

import itertools
import math

import pytest
import sympy as sm

from kanedyn.engine._program import Program, fast_eval, total_derivative


@pytest.fixture()
def program():
    t = sm.Symbol("t")
    prog = Program(t)
    q1, q2, u1, u2, k = sm.symbols("q1 q2 u1 u2 k")
    for q, u in ((q1, u1), (q2, u2)):
        prog.declare(q, u)  # q' = u
        prog.declare(u)     # u' held at zero
    c = prog.let(sm.cos(q1), "c")
    s = prog.let(sm.sin(q2), "s")
    a = prog.let(c * s + k * q1 ** 2, "a")
    b = prog.let(a * u1 + sm.exp(a) * u2 + t * q2, "b")
    return prog, (q1, q2, u1, u2, k, t), (a, b)


def test_hash_consing_and_trivial_values(program):
    prog, (q1, q2, *_), (a, b) = program
    assert prog.let(sm.cos(q1)) == prog.let(sm.cos(q1))
    assert prog.let(q1) is q1
    assert prog.let(3 * q1) == 3 * q1


def test_diff_matches_explicit(program):
    prog, (q1, q2, u1, u2, k, t), (a, b) = program
    explicit_b = prog.expand(b)
    for var in (q1, q2, u1, u2, k):
        got = prog.expand(prog.diff(b, var))
        assert sm.simplify(got - explicit_b.diff(var)) == 0


def test_dt_holds_speeds_fixed(program):
    prog, (q1, q2, u1, u2, k, t), (a, b) = program
    explicit_b = prog.expand(b)
    expected = explicit_b.diff(t) + explicit_b.diff(q1) * u1 + explicit_b.diff(q2) * u2
    assert sm.simplify(prog.expand(prog.dt(b)) - expected) == 0


def test_subs_and_hint(program):
    prog, (q1, q2, u1, u2, k, t), (a, b) = program
    assert sm.simplify(prog.expand(prog.subs(b, {u1: 0, k: 2}))
                       - prog.expand(b).subs({u1: 0, k: 2})) == 0
    # a recorded time derivative is used instead of the chain rule
    x = prog.let(sm.sin(q1) * u2 + 1, "x")
    marker = sm.Symbol("marker")
    prog.hint_dt(x, marker)
    assert prog.dt(2 * x) == 2 * marker


def test_let_tree_shares_repeated_subtrees():
    prog = Program(sm.Symbol("t"))
    q = sm.symbols("q0:4")
    big = sm.cos(q[0] + q[1]) * sm.sin(q[2] * q[3] + q[0]) + sm.cos(q[0] + q[1]) ** 2
    compact = prog.let_tree(big, "w", threshold=3)
    assert sm.simplify(prog.expand(compact) - big) == 0
    defs = [prog.definition(s) for s in prog.needed([compact])]
    assert sum(1 for d in defs if d.func == sm.cos) == 1


def test_let_tree_keeps_min_and_max_without_evaluating_them_again(monkeypatch):
    """A ``Min``/``Max`` whose arguments become names is rebuilt unevaluated (the
    same values): evaluated again, SymPy would compare its new arguments by
    factoring their differences, milliseconds a node."""
    prog = Program(sm.Symbol("t"))
    q, w = sm.symbols("q0:3"), sm.Symbol("w", positive=True)
    speed = sm.Max(sm.sqrt((q[0] * q[1] + sm.cos(q[2])) ** 2 + w), 0.1)
    clipped = sm.Min(speed * sm.sin(q[2] + q[0] * q[1]), 3 * w)
    calls = []
    for kind in (sm.Min, sm.Max):
        find = kind._find_localzeros.__func__
        monkeypatch.setattr(kind, "_find_localzeros", classmethod(
            lambda cls, values, **kw: calls.append(cls) or find(cls, values, **kw)))
    compact = prog.let_tree(clipped, "w", threshold=3)
    assert calls == []
    kinds = [type(prog.definition(s)) for s in prog.needed([compact])]
    assert sm.Min in kinds and sm.Max in kinds
    values = {q[0]: 0.7, q[1]: -1.3, q[2]: 0.4, w: 0.02}
    assert float(prog.expand(compact).subs(values)) == pytest.approx(
        float(clipped.subs(values)), rel=1e-15)


def test_total_derivative_special_functions():
    x, y = sm.symbols("x y", real=True)
    dx, dy = sm.symbols("dx dy")
    for e in (sm.atan2(y, x), sm.tan(x * y), sm.log(x) * sm.asin(y / 3),
              sm.sqrt(x ** 2 + y ** 2), sm.Abs(x - y), x ** y):
        got = total_derivative(e, lambda s: {x: dx, y: dy}.get(s, 0))
        expected = e.diff(x) * dx + e.diff(y) * dy
        vals = {x: 0.7, y: 1.9, dx: 0.3, dy: -1.1}
        assert float(got.subs(vals)) == pytest.approx(float(expected.subs(vals)), rel=1e-12)


def test_fast_eval_agrees_with_evalf():
    x, y = sm.symbols("x y")
    e = sm.sin(x) ** 2 * sm.exp(-y) + sm.sqrt(x * y) / (1 + sm.atan2(y, x)) + sm.pi
    vals = {x: 0.3, y: 2.2}
    got = fast_eval(e, lambda s: vals[s], {})
    assert got.real == pytest.approx(float(e.subs(vals).evalf()), rel=1e-14)
    assert math.isclose(got.imag, 0.0, abs_tol=1e-15)


def test_shadow_values_are_consistent(program):
    prog, _, (a, b) = program
    first = prog.shadow([b], 1)[0]
    again = prog.shadow([b, a], 1)[0]
    other = prog.shadow([b], 2)[0]
    assert first == again
    assert first != other


def test_fast_eval_distinguishes_numbers_with_equal_hashes():
    """hash(-1) == hash(-2) in CPython: the hash-keyed memo must not mix them
    (it evaluated -2*x as -x in randomized identity tests)."""
    from kanedyn.engine._program import fast_eval
    x, y = sm.symbols("x y")
    values = {x: 3.0, y: 5.0}
    expr = -x * y + 2 * x - 2 * y  # contains the numbers -1 and -2
    assert fast_eval(expr, values.__getitem__, {}) == complex(expr.subs(values))


def test_shadow_jacobian_equals_the_symbolic_derivatives(program):
    prog, (q1, q2, u1, u2, k, t), (a, b) = program
    exprs = [a, b, a * b, k]
    variables = (q1, q2, u1, u2, k)
    for seed in (101, 202):
        jacobian = prog.shadow_jacobian(exprs, variables, seed)
        assert jacobian.shape == (4, 5)
        for j, var in enumerate(variables):
            symbolic = prog.shadow([prog.diff(e, var) for e in exprs], seed)
            for x, y in zip(jacobian[:, j], symbolic):
                assert abs(x - y.real) <= 1e-13 * max(1.0, abs(y))
    assert abs(jacobian[3, 4] - 1.0) == 0 and not jacobian[3, :4].any()


def test_shadow_jacobian_refuses_non_analytic_functions(program):
    prog, (q1, q2, u1, u2, k, t), (a, b) = program
    c = prog.let(sm.Abs(a - 1) * u1, "c")
    assert prog.shadow_jacobian([c], (q1,), 101) is None
    assert prog.shadow_jacobian([b], (q1,), 101) is not None


def _temporaries():
    import itertools
    return (sm.Dummy(f"kd_cse{i}", dummy_index=i) for i in itertools.count())


def _sympys_elimination(exprs):
    from sympy.core.parameters import evaluate
    from sympy.simplify.cse_main import tree_cse
    with evaluate(False):
        return tree_cse(exprs, _temporaries(), opt_subs={}, order="none")


def _same_elimination(ours, theirs):
    """The same temporaries (names, trees node for node) and reduced expressions."""
    (r1, e1), (r2, e2) = ours, theirs
    assert [(s.name, t) for s, t in r1] == [(s.name, t) for s, t in r2]
    assert [sm.srepr(t) for _, t in r1] == [sm.srepr(t) for _, t in r2]
    assert [sm.srepr(e) for e in e1] == [sm.srepr(e) for e in e2]


def test_listing_elimination_is_sympys_repeated_subtree_pass():
    """The elimination of ``Program.listing`` gives what SymPy's ``tree_cse``
    gives (no optimizations, ``order="none"``, unevaluated): on small cases
    (a repeated product, a function, a Piecewise's pairs, a symbol named as a
    temporary would be) and on the dynamics and energy of built-in models."""
    from kanedyn.engine._cse import eliminate_repeated
    a, b, c = sm.symbols("a b c")
    taken = sm.Symbol("kd_cse0")
    cases = [[a * b + sm.sin(a * b), sm.cos(a * b) * (a + c)],
             [sm.Piecewise((a * b, c > a * b), (sm.sin(c) ** 2, True)), sm.sin(c) * a * b],
             [taken * (a + b), (a + b) ** 2 + taken], [a, sm.Integer(3)], []]
    for exprs in cases:
        _same_elimination(eliminate_repeated(exprs, _temporaries()),
                          _sympys_elimination(exprs))
    import kanedyn as kd
    for name, options in (("chain3d", {"n": 4}), ("four-bar", {}), ("rolling-disk", {})):
        d = kd.models.build(name, lazy=False, **options)
        eom = d.derive()
        program = eom._program
        dynamics = [e for row in eom._mass for e in row] + list(eom._active) \
            + list(eom._remainder)
        for outputs in (dynamics, [eom._kinetic]):
            exprs = [program.definition(s) for s in program.needed(outputs)] + outputs
            assert exprs, name
            _same_elimination(eliminate_repeated(exprs, _temporaries()),
                              _sympys_elimination(exprs))


def test_time_derivative_is_sympys_derivative():
    """``time_derivative`` builds a dynamic symbol's derivative without SymPy's
    evaluation: the same object as ``diff``; other expressions go to ``diff``."""
    import sympy.physics.mechanics as me

    from kanedyn.engine import time_derivative
    t = me.dynamicsymbols._t
    q = me.dynamicsymbols("q")
    f = sm.Function("f")
    x = sm.Symbol("x")
    for expr in (q, q.diff(t), sm.sin(q) * q, f(t, x), f(x), x, sm.Integer(2)):
        made, expected = time_derivative(expr, t), expr.diff(t)
        assert made == expected and made.args == expected.args
        assert type(made) is type(expected) and hash(made) == hash(expected)


# ------------------------------------- products and sums built without flatten
def _same(got, expected):
    """The same SymPy tree: type, arguments in the same order, hash."""
    return (type(got) is type(expected) and got == expected and got.args == expected.args
            and hash(got) == hash(expected))


def test_product_rule_terms_are_sympys_products():
    """Each product-rule term built by ``_replaced_factor`` is the tree
    ``Mul(*args)`` gives with ``args[i]`` replaced (where it declines, the
    caller calls ``Mul``): float and rational coefficients, symbols sorted
    in, derivatives that are products, sums, powers and functions; products
    that ``Mul.flatten`` reshapes (a repeated base, ``exp`` times ``exp``, a
    number times a sum, powers of numbers) are declined."""
    from kanedyn.engine._program import _plain_product, _replaced_factor
    x, y, z, w = sm.symbols("x y z w")
    a, b = sm.Dummy("a"), sm.Dummy("b")
    products = [2 * x * y, sm.Float(-1.5) * x * sm.sin(y) * z ** 2, x * y * z,
                sm.Rational(3, 7) * sm.exp(x) * (y + z), x * (y + z), -x * sm.cos(a),
                sm.sqrt(2) * x * y, x ** sm.Rational(1, 2) * y, sm.exp(x) * y * w, a * b * x]
    derivatives = [sm.S(3), sm.Float(0.25), sm.Rational(-1, 2), a, b, x, y, 2 * a,
                   -b, sm.Float(2.0) * z, sm.cos(x), x * w, 3 * x * y, y + w, z ** 3,
                   sm.exp(w), sm.S(-1), a ** -1, x ** 2, sm.sqrt(3) * a, w * (x + y)]
    built = declined = 0
    for product in products:
        args = product.args
        plain = _plain_product(args)
        for i in range(len(args)):
            for da in derivatives:
                got = False if plain is False else _replaced_factor(plain, i, da)
                if got is None or got is False:
                    declined += 1
                    continue
                built += 1
                assert _same(got, sm.Mul(*(args[:i] + (da,) + args[i + 1:]))), (product, i, da)
    assert built > 300 and declined > 50


def test_sums_are_sympys_sums():
    """``_sum`` gives the tree ``Add(*terms)`` gives, sums among the terms
    flattened, like terms and numbers left to ``Add``; ``_times``, ``_plus``
    and ``difference`` give what ``*``, ``+`` and ``-`` give (Python integers
    too: ``2 * 3`` stays an int)."""
    from kanedyn.engine._program import difference, _plus, _sum, _times
    x, y, z = sm.symbols("x y z")
    a = sm.Dummy("a")
    pool = [x, 2 * x, x * y, sm.Float(-0.5) * x * y, sm.sin(a), a ** 2, sm.exp(z), y + z,
            3 * a - x, sm.S(2), sm.Float(1.5), sm.S.Zero, x ** -1, 2 * sm.cos(x) * y,
            sm.sqrt(2) ** -1, a]
    for n in range(1, 4):
        for terms in itertools.product(pool, repeat=n):
            assert _same(_sum(list(terms)), sm.Add(*terms)), terms
    for a, b in itertools.product(pool + [2, -1], repeat=2):
        for mine, operator in ((_times, a * b), (_plus, a + b), (difference, a - b)):
            got = mine(a, b)
            assert type(got) is type(operator) and got == operator, (mine, a, b)
            assert not isinstance(got, sm.Basic) or _same(got, operator), (mine, a, b)


@pytest.mark.parametrize("name", ["chain3d", "four-bar", "snake"])
def test_model_derivatives_built_as_sympy_builds_them(name, monkeypatch):
    """Every product-rule term, sum, product and difference built without
    ``Mul`` and ``Add`` while a model's exact derivatives are formed
    (``_specification``, with the parameter columns: ``total_derivative``
    and, for chain3d, the tree's spatial formulas) is the tree SymPy's
    constructors and operators give: chain3d 1517 product-rule terms, 4894
    sums, 2529 products, 450 sums and 720 differences of two, the four-bar
    375 terms and 739 sums, the snake (inputs) 2439 and 6278, all the same (so
    are those of the Panda, the shuttle arm, chain3d at n = 10 and the OC3
    spar variants, checked apart: some seconds each)."""
    import kanedyn as kd
    from kanedyn.engine import _program, _tree_derivatives
    from kanedyn.numerics._jacobians import _specification
    real = {name: getattr(_program, name) for name in ("_replaced_factor", "_sum", "_times",
                                                       "_plus", "difference")}
    counts = dict.fromkeys(real, 0)

    def factor(product, i, da):
        got = real["_replaced_factor"](product, i, da)
        if got is not None:
            coefficient, factors, _ = product
            args = ((coefficient,) if coefficient is not sm.S.One else ()) + tuple(factors)
            assert _same(got, sm.Mul(*(args[:i] + (da,) + args[i + 1:])))
            counts["_replaced_factor"] += 1
        return got

    def checked(key, expected):
        def built(*args):
            got = real[key](*args)
            want = expected(*args)
            assert _same(got, want) if isinstance(want, sm.Basic) else got == want
            counts[key] += 1
            return got
        return built

    monkeypatch.setattr(_program, "_replaced_factor", factor)
    monkeypatch.setattr(_program, "_sum", checked("_sum", lambda terms: sm.Add(*terms)))
    monkeypatch.setattr(_tree_derivatives, "_plain_sum", _program._sum)
    for key, operator in (("_times", lambda a, b: a * b), ("_plus", lambda a, b: a + b),
                          ("difference", lambda a, b: a - b)):
        monkeypatch.setattr(_tree_derivatives, key, checked(key, operator))
    model = kd.models.build(name).numeric(backend="numpy")
    _specification(model, True)
    assert counts["_replaced_factor"] > 300 and counts["_sum"] > 500, counts
    if name == "chain3d":
        assert counts["_times"] > 2000 and counts["difference"] > 500, counts
