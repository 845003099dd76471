"""hapvox from Python: volumes, traces, models, replays, sessions and the 1 kHz force stage.

    import hapvox
    session = hapvox.replay(volume="data/engine_256x256x128_uint8.nrrd",
                            trace="traces/engine_press.csv", tool_diameter_mm=6)
    session["force_n"]          # numpy array, shape (ticks, 3)

Every bad input raises hapvox.InputError (a ValueError) with the one line `hapvox` prints
for it. docs/api.md has the whole API.
"""

from ._hapvox import (  # noqa: F401
    Device,
    ForceStage,
    ForceTick,
    InputError,
    Model,
    RunSummary,
    Session,
    Trace,
    Volume,
    __version__,
    replay,
    run_lockstep,
    run_realtime,
    run_sweep_row,
)
