"""evaluate() and evaluate_iso(): the CLI's values on the same inputs, broadcasting, bad input,
progress and Ctrl-C."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import microshadow as ms
from conftest import random_queries, read_csv_columns, write_queries


def _cli_eval(cli, tmp_path, queries, *options):
    q = tmp_path / "q.csv"
    r = tmp_path / "r.csv"
    write_queries(q, *queries)
    cli("eval", "--in", q, "--out", r, "-q", *options)
    cols = read_csv_columns(r)
    return np.array([float(x) for x in cols["term"]]), np.array([float(x) for x in cols["std_error"]])


def test_exact_on_the_oracle_gives_the_clis_values(cli, tmp_path):
    queries = random_queries(40)
    term, err = ms.evaluate(*queries, backend="oracle", tolerance=1e-8)
    want_term, want_err = _cli_eval(cli, tmp_path, queries, "--backend", "oracle", "--tolerance", "1e-8")
    np.testing.assert_array_equal(term, want_term)
    np.testing.assert_array_equal(err, want_err)
    assert term[0] == 1.0 and err[0] == 0.0  # visibility 1 is exact
    assert (err <= 1e-8).all()


def test_sampled_gives_the_clis_values_for_every_option(cli, tmp_path):
    queries = random_queries(12, seed=8)
    options = dict(method="sampled", samples=512, replicates=4, seed=7, sequence="random", form="uncorrelated",
                   ao_weighting="uniform", backend="oracle")
    term, err = ms.evaluate(*queries, **options)
    want_term, want_err = _cli_eval(cli, tmp_path, queries, "--method", "sampled", "--samples", "512",
                                    "--replicates", "4", "--seed", "7", "--sequence", "random", "--form",
                                    "uncorrelated", "--ao-weighting", "uniform", "--backend", "oracle")
    np.testing.assert_array_equal(term, want_term)
    np.testing.assert_array_equal(err, want_err)
    assert (err[1:] > 0).any()


def test_default_device_gives_the_clis_values(cli, tmp_path):
    # The default backend (OpenCL on the default device) and method (exact), as the command's.
    queries = random_queries(6, seed=3)
    term, err = ms.evaluate(*queries, tolerance=1e-6)
    want_term, want_err = _cli_eval(cli, tmp_path, queries, "--tolerance", "1e-6")
    np.testing.assert_array_equal(term, want_term)
    np.testing.assert_array_equal(err, want_err)


def test_numbers_and_arrays_broadcast():
    wi = np.array([[0.6, 0.0, 0.8], [0.0, 0.6, 0.8], [0.3, 0.3, 0.9]])
    term, err = ms.evaluate(0.5, 0.3, 0.3, wi, [0.0, 0.0, 1.0], backend="oracle", tolerance=1e-8)
    assert term.shape == err.shape == (3,)
    full, _ = ms.evaluate(np.full(3, 0.5), np.full(3, 0.3), [0.3, 0.3, 0.3], wi, np.tile([0.0, 0.0, 1.0], (3, 1)),
                          backend="oracle", tolerance=1e-8)
    np.testing.assert_array_equal(term, full)
    # An isotropic surface: a view rotated about the normal gives the same term to the tolerance.
    assert abs(term[0] - term[1]) < 1e-7
    one, _ = ms.evaluate(0.5, 0.3, 0.3, [0.6, 0.0, 0.8], [0.0, 0.0, 1.0], backend="oracle", tolerance=1e-8)
    assert one.shape == (1,) and one[0] == term[0]
    empty, empty_err = ms.evaluate(np.empty(0), 0.3, 0.3, np.empty((0, 3)), [0, 0, 1])
    assert empty.shape == empty_err.shape == (0,)


def test_evaluate_iso_is_evaluate_on_the_sweeps_directions():
    v = np.array([0.4, 0.7, 0.9])
    r = np.array([0.3, 0.6, 1.0])
    nv, nl, phi = 0.7, np.array([0.2, 0.5, 0.9]), np.array([0.0, 90.0, 180.0])
    term, err = ms.evaluate_iso(v, nl, nv, roughness=r, relative_azimuth_deg=phi, backend="oracle", tolerance=1e-8)
    s_v, s_l = np.sqrt(1 - nv * nv), np.sqrt(1 - nl * nl)
    rad = np.radians(phi)
    wi = np.tile([s_v, 0.0, nv], (3, 1))
    wo = np.stack([s_l * np.cos(rad), s_l * np.sin(rad), nl], axis=1)
    want, _ = ms.evaluate(v, r * r, r * r, wi, wo, backend="oracle", tolerance=1e-8)
    np.testing.assert_allclose(term, want, rtol=0, atol=1e-12)
    with pytest.raises(TypeError, match="samplez"):
        ms.evaluate_iso(0.5, 0.5, 0.5, roughness=0.5, samplez=3)


def test_evaluate_iso_takes_the_lookups_order_and_broadcasts_like_it():
    # visibility, n_dot_l, n_dot_v, then roughness by name only: a number in its place by position
    # (an alpha, say) is refused, not read as a roughness.
    with pytest.raises(TypeError):
        ms.evaluate_iso(0.5, 0.5, 0.5, 0.3)
    v, nl = np.linspace(0.2, 0.9, 4)[:, None], np.linspace(0.1, 1.0, 3)[None, :]
    grid, err = ms.evaluate_iso(v, nl, 0.7, roughness=0.5, backend="oracle", tolerance=1e-8)
    assert grid.shape == err.shape == (4, 3)
    flat, _ = ms.evaluate_iso(np.repeat(v[:, 0], 3), np.tile(nl[0], 4), 0.7, roughness=0.5, backend="oracle",
                              tolerance=1e-8)
    np.testing.assert_array_equal(grid.reshape(-1), flat)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: ms.evaluate([0.5, np.nan], 0.3, 0.3, [0, 0, 1], [0, 0, 1]), r"visibility\[1\] = nan: not a finite"),
        (lambda: ms.evaluate([0.5, 1.5], 0.3, 0.3, [0, 0, 1], [0, 0, 1]), r"visibility\[1\] = 1.5: outside \[0, 1\]"),
        (lambda: ms.evaluate(0.5, [0.3, 0.3, -0.1], 0.3, [0, 0, 1], [0, 0, 1]), r"alpha_x\[2\] = -0.1: must be > 0"),
        (lambda: ms.evaluate(0.5, 0.3, np.inf, [0, 0, 1], [0, 0, 1]), r"alpha_y = inf: not a finite"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [[0, 0, 1], [0, 0, 0]], [0, 0, 1]), r"wi\[1\] = .*zero-length"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [[0, 0, 1], [1, 0, -0.2]], [0, 0, 1]), r"wi\[1\] = .*below the horizon"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], [[0, 0, 1], [0, np.nan, 1]]), r"wo\[1, 1\] = nan"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [[0, 1], [1, 0]], [0, 0, 1]), r"wi: shape \(2, 2\); expected \(3,\) or \(N, 3\)"),
        (lambda: ms.evaluate([[0.5]], 0.3, 0.3, [0, 0, 1], [0, 0, 1]), r"visibility: shape \(1, 1\)"),
        (lambda: ms.evaluate([0.5, 0.6], 0.3, 0.3, np.tile([0, 0, 1], (3, 1)), [0, 0, 1]),
         r"visibility has 2 queries and wi has 3"),
        (lambda: ms.evaluate("x", 0.3, 0.3, [0, 0, 1], [0, 0, 1]), r"visibility: not an array of numbers"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], [0, 0, 1], method="monte-carlo"), r"method = 'monte-carlo'"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], [0, 0, 1], replicates=1), r"replicates = 1"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], [0, 0, 1], tolerance=1e-20), r"tolerance = 1e-20"),
        (lambda: ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], [0, 0, 1], device=3), r"device = 3"),
        (lambda: ms.evaluate_iso(0.5, 0.5, 0.5, roughness=[0.5, 0.0]), r"roughness\[1\] = 0.0: outside \(0, 1\]"),
        (lambda: ms.evaluate_iso(0.5, 0.5, [1.0, 0.0], roughness=0.5), r"n_dot_v\[1\] = 0.0: outside \(0, 1\]"),
        (lambda: ms.evaluate_iso(0.5, [0.2, 1.2], 0.5, roughness=0.5), r"n_dot_l\[1\] = 1.2: outside \[-1, 1\]"),
        (lambda: ms.evaluate_iso(0.5, 0.5, 0.5, roughness=0.5, relative_azimuth_deg=[0.0, np.nan]), r"relative_azimuth_deg\[1\] = nan"),
    ],
)
def test_bad_input_is_a_value_error_naming_the_argument_and_index(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_complex_numbers_are_refused_not_cut_to_their_real_part():
    with pytest.raises(ValueError, match=r"visibility: not an array of numbers \(complex numbers"):
        ms.evaluate([0.5 + 0.25j], 0.3, 0.3, [0, 0, 1], [0, 0, 1])
    with pytest.raises(ValueError, match=r"wo: not an array of numbers \(complex numbers"):
        ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], np.array([0, 0, 1], dtype=complex))


def test_messages_show_numpy_numbers_as_numbers():
    with pytest.raises(ValueError) as e:
        ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], [0, 0, 1], tolerance=np.float64(np.nan))
    assert "tolerance = nan:" in str(e.value) and "np." not in str(e.value)
    with pytest.raises(ValueError) as e:
        ms.evaluate(0.5, 0.3, 0.3, [[0, 0, 1], [0, 0, 0]], [0, 0, 1])
    assert "wi[1] = (0.0, 0.0, 0.0)" in str(e.value)


def test_a_call_larger_than_memory_fails_before_any_work():
    # Ten billion queries as a zero-stride view (no memory of its own): refused from the shapes alone,
    # before the checks and copies that would run out of memory only after seconds.
    many = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (10**10, 3))
    with pytest.raises(MemoryError, match=r"10000000000 queries need about .* GiB, more than this machine's"):
        ms.evaluate(0.5, 0.3, 0.3, many, [0, 0, 1], backend="oracle")


def test_a_light_below_the_horizon_is_legal_and_gives_zero():
    term, err = ms.evaluate(0.5, 0.3, 0.3, [0, 0, 1], [0.6, 0, -0.8], backend="oracle")
    assert term[0] == 0.0 and err[0] == 0.0


def test_progress_reports_reach_the_total():
    seen = []
    v, ax, ay, wi, wo = random_queries(30)
    ms.evaluate(v, ax, ay, wi, wo, backend="oracle", tolerance=1e-6, progress=lambda d, t: seen.append((d, t)))
    assert seen and seen[-1] == (30, 30)
    assert all(t == 30 and 0 <= d <= 30 for d, t in seen)


def test_progress_true_prints_on_stderr(capsys):
    ms.evaluate(0.5, 0.3, 0.3, [0.6, 0, 0.8], [0, 0, 1], backend="oracle", tolerance=1e-6, progress=True)
    assert "evaluate: 1/1 (100 %)" in capsys.readouterr().err


def test_an_exception_in_the_progress_callback_stops_the_call_and_propagates():
    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop("enough")

    with pytest.raises(Stop, match="enough"):
        ms.evaluate(*random_queries(50), backend="oracle", tolerance=1e-6, progress=stop)
    # The engine's stop flag is lowered again: the next call runs to the end.
    term, _ = ms.evaluate(0.5, 0.3, 0.3, [0.6, 0, 0.8], [0, 0, 1], backend="oracle", tolerance=1e-6)
    assert term[0] > 0


def test_ctrl_c_stops_a_long_call_with_keyboard_interrupt():
    # 4,000,000 exact queries take several seconds; SIGINT 0.2 s in must stop them within the calling
    # thread's signal check (every 0.1 s) and a batch.
    n = 4_000_000
    rng = np.random.default_rng(1)
    nl = rng.uniform(0.05, 1.0, n)
    # Python's own Ctrl-C handler, whatever this process inherited: a shell starts background jobs with
    # SIGINT ignored, and Python then leaves it ignored.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            ms.evaluate_iso(0.6, nl, 0.7, roughness=0.5, relative_azimuth_deg=60.0, backend="oracle")
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    elapsed = time.monotonic() - start
    assert elapsed < 3.0, f"stopped only after {elapsed:.1f} s"
    term, _ = ms.evaluate_iso(0.6, 0.5, 0.7, roughness=0.5, relative_azimuth_deg=60.0, backend="oracle")
    assert term > 0  # scalars broadcast to a 0-d array, as a lookup gives


def test_a_long_call_releases_the_gil():
    # While evaluate() runs in a worker thread (between its first and its last progress report), the
    # main thread keeps running Python: with the GIL held it could run only inside the reports.
    n = 20_000
    nl = np.random.default_rng(2).uniform(0.05, 1.0, n)
    state = {"in_call": False, "done": False}
    reports = []

    def progress(done, total):
        state["in_call"] = True
        reports.append(done)

    def work():
        ms.evaluate_iso(0.6, nl, 0.7, roughness=0.5, relative_azimuth_deg=60.0, backend="oracle", tolerance=1e-8,
                        progress=progress)
        state["done"] = True

    worker = threading.Thread(target=work)
    worker.start()
    counted = 0
    while not state["done"]:
        if state["in_call"]:
            counted += 1
    worker.join()
    assert reports[-1] == n
    assert counted > 10_000, f"the main thread ran {counted} steps during the call"


def test_relative_azimuth_deg_is_the_one_name_and_the_older_one_still_works_with_a_warning():
    # One spelling in C++ (LookupInputs::relative_azimuth_deg), the design CSV and Python; the older
    # Python keyword gives the same values with a DeprecationWarning, and both at once are refused.
    new, _ = ms.evaluate_iso(0.6, 0.5, 0.7, roughness=0.5, relative_azimuth_deg=60.0, backend="oracle", tolerance=1e-8)
    with pytest.warns(DeprecationWarning, match=r"relative_azimuth=\) is deprecated: use relative_azimuth_deg="):
        old, _ = ms.evaluate_iso(0.6, 0.5, 0.7, roughness=0.5, relative_azimuth=60.0, backend="oracle", tolerance=1e-8)
    assert old == new
    with pytest.raises(TypeError, match="both relative_azimuth= and relative_azimuth_deg="):
        ms.evaluate_iso(0.6, 0.5, 0.7, roughness=0.5, relative_azimuth=60.0, relative_azimuth_deg=60.0)
    inputs = ms.lookup_inputs(0.6, 0.3, 0.3, [0.6, 0.0, 0.8], [-0.6, 0.0, 0.8])
    assert set(inputs) == {"visibility", "n_dot_l", "n_dot_v", "roughness", "relative_azimuth_deg"}
