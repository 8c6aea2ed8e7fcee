"""``kanedyn sweep``: a grid on the command line gives the table kd.sweep gives;
bad arguments (a scheduler that is not one among them) are one-line errors
with exit code 2; a run over --run-timeout is a failed row."""

import http.server
import threading

import numpy as np
import pytest

import kanedyn as kd
from kanedyn.cli import main
from kanedyn.cli._sweep import parse_grid

pd = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")


def test_grid_syntax():
    np.testing.assert_array_equal(parse_grid("1:2:11", "m"), np.linspace(1, 2, 11))
    np.testing.assert_array_equal(parse_grid("0.5,1,2*pi", "l"), [0.5, 1.0, 2 * np.pi])


def test_sweep_command_matches_the_api(tmp_path, capsys):
    out = tmp_path / "s"
    code = main(["sweep", "pendulum", "--grid", "l=0.5:2:3", "--grid", "q=0.1,0.2",
                 "--out", str(out), "--t-end", "1", "--scheduler", "serial", "--quiet",
                 "--csv", "--backend", "numpy"])  # the API's default backend: same numbers
    assert code == 0 and "6 runs, 0 failed" in capsys.readouterr().out
    table = pd.read_csv(out / "results.csv")
    d = kd.models.build("pendulum")
    model = d.numeric(d.derive())
    expected = kd.sweep(model, {"l": [0.5, 1.25, 2.0], "q": [0.1, 0.2]}, d.initial(model),
                        (0.0, 1.0), outputs=("final",), scheduler="serial", progress=False)
    np.testing.assert_allclose(table["final_q"], expected["final_q"], rtol=1e-15, atol=0)
    assert table["l"].tolist() == [0.5, 0.5, 1.25, 1.25, 2.0, 2.0]


@pytest.mark.parametrize("argv, message", [
    (["--grid", "l=1:2"], "start:stop:count"),
    (["--grid", "l=1:2:x"], "whole number"),
    (["--grid", "l=abc"], "'abc' is not a number"),
    (["--grid", "l=__import__('os')"], "is not a number"),
    (["--grid", "l=1,,2"], "empty value"),
    (["--random", "l=1:2"], "needs --samples"),
    (["--random", "l=2:1", "--samples", "3"], "low must be below high"),
    (["--grid", "l=1", "--random", "m=1:2", "--samples", "2"], "not both"),
    (["--grid", "l=1", "--t-end", "0"], "argument --t-end: must be a finite number > 0"),
    (["--grid", "l=1", "--workers", "0"], "--workers must be at least 1"),
    (["--grid", "l=1", "--run-timeout", "0"], "argument --run-timeout: must be a finite number"),
    (["--grid", "l=1", "--scheduler", "garbage"],
     "scheduler 'garbage' is not a Dask scheduler address (missing port"),
    (["--grid", "l=1", "--scheduler", "tcp://:x"], "is not a Dask scheduler address"),
    (["--grid", "l=1", "--outputs", "final,peak"], "--outputs: unknown peak"),
    (["--grid", "length=1", "--t-end", "0.1", "--scheduler", "serial"],
     "--grid length: not a parameter or state of pendulum"),
    ([], "at least one --grid"),
])
def test_bad_arguments(tmp_path, capsys, argv, message):
    code = main(["sweep", "pendulum", "--out", str(tmp_path / "o"), "--quiet", *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and len(err.splitlines()) == 1


def test_unwritable_out(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code = main(["sweep", "pendulum", "--grid", "l=1", "--out", str(blocker / "sub")])
    assert code == 2 and "is a file, not a folder" in capsys.readouterr().err


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _main_within(seconds, argv):
    """``main(argv)``'s exit code, waiting at most ``seconds`` (a hang guard)."""
    box = {}
    thread = threading.Thread(target=lambda: box.setdefault("code", main(argv)), daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"kanedyn {' '.join(argv)} did not return in {seconds} s"
    return box["code"]


def test_an_http_server_as_scheduler_is_a_one_line_error(tmp_path, capsys):
    """An HTTP server accepts the connection and never answers as Dask: the
    sweep stopped only after more than 180 s with a traceback; now a one-line
    error (hang guard: 60 s), before the model is derived."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _QuietHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    address = f"tcp://127.0.0.1:{server.server_address[1]}"
    try:
        code = _main_within(60, ["sweep", "pendulum", "--grid", "l=1", "--out",
                                 str(tmp_path / "o"), "--quiet", "--scheduler", address])
    finally:
        server.shutdown()
        server.server_close()
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert f"scheduler {address}: no Dask scheduler answered" in err


def test_run_timeout(tmp_path, capsys):
    """A pendulum run of 1e6 s on the numpy backend takes minutes: with
    --run-timeout 1 it is a failed row naming the limit (hang guard: 120 s)."""
    out = tmp_path / "t"
    code = _main_within(120, ["sweep", "pendulum", "--grid", "l=1", "--t-end", "1e6",
                              "--backend", "numpy", "--scheduler", "serial", "--quiet",
                              "--csv", "--outputs", "t_end", "--run-timeout", "1",
                              "--out", str(out)])
    assert code == 1 and "1 runs, 1 failed" in capsys.readouterr().out
    row = pd.read_csv(out / "results.csv").iloc[0]
    assert not row["success"] and "time limit of 1 s" in row["message"]
    assert 0 < row["t_end"] < 1e6
