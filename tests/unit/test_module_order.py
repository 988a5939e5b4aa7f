"""The order make test hands the test modules out in (tests/conftest.py ``module_order``):
longest first, and a browser module (Chromium, a commander and a controller at once) beside
another kind of module whenever one is left, never beside a second browser module."""

from __future__ import annotations

from tests.conftest import module_order


def _lanes(order: list[str], seconds: dict[str, float], workers: int) -> list[tuple[float, float, str]]:
    """(start, end, module) as ``workers`` processes that each take the next module when free."""
    free = [0.0] * workers
    out = []
    for m in order:
        i = min(range(workers), key=free.__getitem__)
        out.append((free[i], free[i] + seconds[m], m))
        free[i] += seconds[m]
    return out


def test_browser_modules_run_beside_other_modules_longest_first():
    seconds = {f"tests/browser/test_b{k}.py": 100.0 - 7 * k for k in range(8)}
    seconds |= {f"tests/integration/test_i{k}.py": 90.0 - 5 * k for k in range(8)}
    seconds |= {f"tests/unit/test_u{k}.py": 3.0 for k in range(20)}
    order = module_order(seconds, 2)
    assert sorted(order) == sorted(seconds)
    runs = _lanes(order, seconds, 2)
    browser = [(a, b) for a, b, m in runs if m.startswith("tests/browser/")]
    assert all(b1 <= a2 or b2 <= a1 for i, (a1, b1) in enumerate(browser) for a2, b2 in browser[i + 1:])
    for kind in ("browser", "integration"):  # each kind's longest first
        mine = [m for m in order if f"/{kind}/" in m]
        assert mine == sorted(mine, key=lambda m: -seconds[m])


def test_with_only_browser_modules_left_they_run_side_by_side():
    seconds = {f"tests/browser/test_b{k}.py": 10.0 for k in range(4)} | {"tests/unit/test_u.py": 1.0}
    order = module_order(seconds, 2)
    assert sorted(order) == sorted(seconds) and order[1] == "tests/unit/test_u.py"
    assert max(b for _, b, _ in _lanes(order, seconds, 2)) == 21.0


def test_one_worker_takes_the_longest_first():
    seconds = {"tests/unit/test_a.py": 1.0, "tests/browser/test_b.py": 5.0, "tests/integration/test_c.py": 3.0}
    assert module_order(seconds, 1) == ["tests/browser/test_b.py", "tests/integration/test_c.py",
                                        "tests/unit/test_a.py"]


def test_the_order_does_not_depend_on_the_order_the_modules_come_in():
    """Every pytest-xdist worker computes it from its own collection and they must agree (a set
    iterated in another order in each process, with ties of equal times, had the workers
    collect differently and the run end at once)."""
    seconds = {f"tests/unit/test_u{k}.py": 2.0 for k in range(30)} | {f"tests/browser/test_b{k}.py": 30.0
                                                                      for k in range(5)}
    backwards = dict(reversed(list(seconds.items())))
    assert module_order(seconds, 2) == module_order(backwards, 2)
