"""The Python bindings (python/bindings.cc), run by ctest as Python.Bindings (pytest).

HAPVOX_SOURCE_DIR (the checkout) and HAPVOX_BINARY (the hapvox command) come from ctest; the
module from PYTHONPATH (BUILD/python, or the installed package).
"""

import os
import subprocess
import threading

import h5py
import numpy as np
import pytest

import hapvox

SOURCE = os.environ.get("HAPVOX_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
HAPVOX = os.environ.get("HAPVOX_BINARY", "hapvox")
CT = os.path.join(SOURCE, "data", "engine_256x256x128_uint8.nrrd")
PRESS = os.path.join(SOURCE, "traces", "engine_press.csv")


def cli(*args):
    return subprocess.run([HAPVOX, *args], capture_output=True, text=True)


def cli_replay(tmp_path, *flags):
    out = str(tmp_path / "cli.h5")
    run = cli("replay", PRESS, "--volume", CT, "-q", "-o", out, *flags)
    assert run.returncode == 0, run.stderr
    return out


def cli_error(run):
    """The line hapvox printed after 'hapvox: error: '."""
    assert run.returncode == 2, run.stderr
    line = run.stderr.split("hapvox: error: ", 1)[1]
    return line.splitlines()[0]


def same_bits(a, b):
    a, b = np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def test_replay_equals_the_command_lines_session_bit_for_bit(tmp_path):
    cli_path = cli_replay(tmp_path, "--tool-diameter-mm", "6", "-E", "50000")
    session = hapvox.replay(volume=CT, trace=PRESS, tool_diameter_mm=6, youngs_modulus_pa=50e3)
    assert session.path == ""  # temporary, read back and removed
    with h5py.File(cli_path, "r") as f:
        for name in ["time_s", "tool_position_mm", "force_n", "displacement_mm", "contact"]:
            assert same_bits(session[name], f[name][...]), name
        assert session.rows == f["time_s"].shape[0]
    assert session.force_n.shape == (session.rows, 3)
    assert np.abs(session.force_n).max() > 0.1  # it touched
    assert session.attributes["tool_diameter_mm"] == "6"


def test_a_session_file_reads_as_h5py_reads_it(tmp_path):
    out = str(tmp_path / "api.h5")
    session = hapvox.replay(volume="block", trace=PRESS, output=out, flags=["--fit"])
    assert session.path == out and session.complete
    with h5py.File(out, "r") as f:
        for name in session.datasets:
            assert same_bits(session[name], f[name][...]), name
    assert "force_n" in session and "nope" not in session
    with pytest.raises(AttributeError):
        session.nope


def test_volumes_and_traces_round_trip_numpy_arrays(tmp_path):
    rng = np.random.default_rng(7)
    density = rng.random((6, 5, 4)).astype(np.float32)  # [i, j, k]
    volume = hapvox.Volume.from_array(density, spacing_mm=(0.5, 1, 2), origin_mm=(1, 2, 3))
    assert volume.dims == [6, 5, 4]
    assert np.array_equal(volume.to_array(), density)
    path = str(tmp_path / "v.nrrd")
    volume.save(path)
    back = hapvox.Volume.load(path)
    assert np.array_equal(back.to_array(), density)
    assert back.origin_mm == [1.0, 2.0, 3.0]
    # Voxel (i, j, k) is density[i, j, k]: a single full voxel lands where it was put.
    one = np.zeros((4, 4, 4), np.float32)
    one[3, 1, 0] = 1.0
    nonzero = np.argwhere(hapvox.Volume.from_array(one).to_array() > 0)
    assert nonzero.tolist() == [[3, 1, 0]]

    t = np.array([0.0, 0.01, 0.02])
    p = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [2.0, 4.0, 6.0]])
    trace = hapvox.Trace.from_arrays(t, p)
    assert same_bits(trace.time_s, t) and same_bits(trace.position_mm, p)
    trace.save(str(tmp_path / "t.csv"))
    back = hapvox.Trace.load(str(tmp_path / "t.csv"))
    assert same_bits(back.position_mm, p)
    times, positions, holding = trace.resampled(1000.0)
    assert times.shape == (21,) and positions.shape == (21, 3) and not holding.any()
    assert positions[5].tolist() == pytest.approx([0.5, 1.0, 1.5])


def test_bad_input_raises_the_command_lines_message(tmp_path):
    out = str(tmp_path / "x.h5")
    run = cli("replay", PRESS, "--volume", CT, "-q", "-o", out, "--poisson", "0.7")
    with pytest.raises(hapvox.InputError) as error:
        hapvox.replay(volume=CT, trace=PRESS, poisson_ratio=0.7)
    assert str(error.value) == cli_error(run)
    assert isinstance(error.value, ValueError)

    bad = tmp_path / "bad.csv"
    bad.write_text("t,x,y,z\n0,1,2,3\n0.001,1,2\n")
    run = cli("replay", str(bad), "--volume", CT, "-q", "-o", out)
    with pytest.raises(hapvox.InputError) as error:
        hapvox.replay(volume=CT, trace=str(bad))
    assert str(error.value) == cli_error(run)
    with pytest.raises(hapvox.InputError) as error:
        hapvox.Trace.load(str(bad))
    assert str(error.value) == cli_error(run)

    missing = str(tmp_path / "none.nrrd")
    run = cli("info", missing)
    with pytest.raises(hapvox.InputError) as error:
        hapvox.Volume.load(missing)
    assert str(error.value) == cli_error(run)
    with pytest.raises(hapvox.InputError, match=r"^array: density 2\.000000 at index 0"):
        hapvox.Volume.from_array(np.full((2, 2, 2), 2.0, np.float32))


def test_stepping_the_force_stage_in_a_python_loop_gives_the_replays_forces(tmp_path):
    with h5py.File(cli_replay(tmp_path), "r") as f:
        replayed = f["force_n"][...]
    model = hapvox.Model.voxel(hapvox.Volume.load(CT))
    _, positions, _ = hapvox.Trace.load(PRESS).resampled()
    stage = hapvox.ForceStage(model)
    forces = np.array([stage.step(p).force_n for p in positions])
    assert stage.ticks == len(positions)
    assert same_bits(forces, replayed)
    # N ticks in one call (the GIL released): the same forces.
    assert same_bits(hapvox.ForceStage(model).step_many(positions), replayed)


def test_the_fem_model_steps_as_its_replay(tmp_path):
    # Nakao's Fig. 6 on a coarse mesh; the command line refines along the trace's path unless
    # told not to (a Model knows no path ahead).
    grab = os.path.join(SOURCE, "traces", "engine_grab.csv")
    materials = os.path.join(SOURCE, "data", "engine_grab.toml")
    flags = ["--interaction", "grab", "--coupling-n-per-mm", "1000", "--spacing-mm", "16",
             "--boundary-levels", "0"]
    out = str(tmp_path / "fem.h5")
    run = cli("replay", grab, "--volume", CT, "-q", "-o", out, "--model", "fem", "--materials",
              materials, "--tool-diameter-mm", "24", "--max-force-n", "10000",
              "--no-tool-refine", *flags)
    assert run.returncode == 0, run.stderr
    model = hapvox.Model.fem(hapvox.Volume.load(CT), materials=materials, tool_diameter_mm=24,
                             flags=flags)
    _, positions, _ = hapvox.Trace.load(grab).resampled()
    forces = hapvox.ForceStage(model, max_force_n=10000).step_many(positions)
    with h5py.File(out, "r") as f:
        assert same_bits(forces, f["force_n"][...])
    assert np.abs(forces).max() > 1.0


def test_a_python_device_callback_drives_a_lockstep_run(tmp_path):
    model = hapvox.Model.voxel(hapvox.Volume.load("block"), tool_diameter_mm=4)
    lo, hi = np.array(model.volume.world_min_mm), np.array(model.volume.world_max_mm)
    centre = 0.5 * (lo + hi)  # the block's clay fills the box's lower half: its top is here
    start = centre + [0, 0, model.tool_radius_mm]
    sent = []
    device = hapvox.Device.callback(
        lambda tick: start - [0, 0, 2.0 * tick / 300], 300,
        on_force=lambda tick, f: sent.append(f))
    summary = hapvox.run_lockstep(model, device, session_path=str(tmp_path / "s.h5"))
    assert summary.ticks == 300 and len(sent) == 300
    session = hapvox.Session.open(str(tmp_path / "s.h5"))
    # The device frame is the volume's here: the forces sent are the session's (up to the
    # rounding of the identity rotation's product).
    np.testing.assert_allclose(np.array(sent), session.force_n, rtol=1e-12, atol=1e-15)
    assert sent[-1][2] > 0.1  # pushed back up


def test_a_raising_callback_is_raised_after_the_run_not_a_crash():
    model = hapvox.Model.voxel(hapvox.Volume.load("block"))

    def read(tick):
        if tick == 7:
            raise KeyError("no sample")
        return [0.0, 0.0, 100.0]

    for run in (hapvox.run_lockstep, hapvox.run_realtime):
        device = hapvox.Device.callback(read, 20)
        with pytest.raises(RuntimeError, match="^device callback read raised at tick 7: KeyError: 'no sample'$"):
            run(model, device)
    device = hapvox.Device.callback(lambda tick: [0.0, 0.0, 100.0], 5,
                                    on_force=lambda tick, f: 1 / 0)
    with pytest.raises(RuntimeError, match="on_force raised at tick 0: ZeroDivisionError: division by zero$"):
        hapvox.run_lockstep(model, device)


def test_a_sweep_row_runs_the_rows_replay(tmp_path):
    manifest = tmp_path / "sweep.toml"
    manifest.write_text(f'traces = ["{PRESS}"]\nvolumes = ["{CT}"]\n'
                        "[options]\ntool-diameter-mm = [4, 8]\n")
    row = hapvox.run_sweep_row(str(manifest), 1)
    with h5py.File(cli_replay(tmp_path, "--tool-diameter-mm", "8"), "r") as f:
        assert same_bits(row.force_n, f["force_n"][...])


def test_long_calls_release_the_gil():
    done = threading.Event()
    counted = [0]

    def run():
        hapvox.replay(volume=CT, trace=PRESS)
        done.set()

    worker = threading.Thread(target=run)
    worker.start()
    while not done.is_set():
        counted[0] += 1
    worker.join()
    # Python ran here while the replay ran there (it holds no GIL): far more than the
    # interpreter's switch interval alone would allow with the GIL held for the whole call.
    assert counted[0] > 100000
