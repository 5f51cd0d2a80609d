"""``raydamp run spec.json``: a job file (the service's job JSON) run in this process, with a
progress bar on a terminal, a summary table, and the solution and an energy plot written
where asked. Exit codes: 0 completed, 1 the run stopped early (blow-up, or cancelled by Ctrl-C:
the summary names the failing step and what was computed is still written), 2 a bad file, spec
or output path (checked before the run)."""

from __future__ import annotations

import json
import shutil
import sys
import threading
from pathlib import Path

from ..jobs import job_arguments
from ..jobs.build import unique_keys
from ..results.io.solution import FORMATS
from ..run.integrate import CancelToken, integrate
from .ctrl_c import ctrl_c_cancels
from .output_paths import file_problem
from .thermal_options import THERMAL_KEYS, with_thermal_options

__all__ = ["run_file", "read_spec"]


def _fail(message: str) -> int:
    print(f"raydamp run: {message}", file=sys.stderr)
    return 2


def _progress_bar(enabled: bool):
    """(callback for integrate, closer): a tqdm bar on a terminal, nothing elsewhere."""
    if not enabled:
        return None, lambda: None
    from tqdm import tqdm

    # A terminal that reports no size (a bare pseudo-terminal: 0 x 0) gets 80 x 24; tqdm would
    # otherwise hide the bar as below the screen's last row.
    size = shutil.get_terminal_size((80, 24))
    bar = tqdm(total=0, unit="step", unit_scale=True, disable=None, ncols=size.columns, nrows=size.lines,
               desc="integrating")

    def update(done: int, total: int) -> None:
        if bar.total != total:
            bar.total = total
        bar.update(done - bar.n)

    return update, bar.close


def _integrate_until_interrupted(model, q0, p0, progress, options: dict):
    """integrate(...), a Ctrl-C cancelling it: the run then ends "cancelled" with the points so far.

    Python runs a signal handler only in the main thread, between bytecodes; the step loop holds
    the main thread in C++ (the GIL released) for the whole run. So the run goes on a worker
    thread while the main thread waits in short joins, where the handler runs at once."""
    if threading.current_thread() is not threading.main_thread():  # no signal handler can be installed here
        return integrate(model, q0, p0, progress=progress, **options)
    cancel = CancelToken()
    outcome: dict = {}

    def run() -> None:
        try:
            outcome["solution"] = integrate(model, q0, p0, progress=progress, cancel=cancel, **options)
        except BaseException as error:  # noqa: BLE001 - handed to the main thread, which reports it
            outcome["error"] = error

    worker = threading.Thread(target=run, name="raydamp-run", daemon=True)
    with ctrl_c_cancels(cancel):
        worker.start()
        while worker.is_alive():
            worker.join(0.1)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["solution"]


def _output_problem(out: str | None, plot: str | None) -> str | None:
    """The first of --out and --plot that cannot be written, checked before the run (which could be long)."""
    for flag, path in (("--out", out), ("--plot", plot)):
        if path is not None and (problem := file_problem(path)):
            return f"{flag} {path}: {problem}"
    return None


def _summary_table(summary: dict) -> str:
    rows = [(key, "-" if value is None else (f"{value:.6g}" if isinstance(value, float) else str(value)))
            for key, value in summary.items()]
    width = max(len(key) for key, _ in rows)
    return "\n".join(f"{key:<{width}}  {value}" for key, value in rows)


def read_spec(spec_path: str):
    """The JSON a job file holds; ValueError naming the file when it cannot be read or parsed, or names a key
    twice (JSON takes the last silently: {"h": 0.1, "h": 10} ran at h = 10, where an unknown key is refused)."""
    try:
        return json.loads(Path(spec_path).read_text(), object_pairs_hook=unique_keys)
    except OSError as error:
        raise ValueError(f"{spec_path}: {error.strerror}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(f"{spec_path}: not JSON ({error})") from None
    except ValueError as error:  # unique_keys: a key named twice
        raise ValueError(f"{spec_path}: {error}") from None
    except RecursionError:  # a traceback before: 100,000 nested brackets
        raise ValueError(f"{spec_path}: nested too deeply to read (a job file is a few levels deep)") from None


def run_file(spec_path: str, *, out: str | None = None, plot: str | None = None, progress: bool = True,
             temperature: float | None = None, seed: int | None = None, stream: int | None = None) -> int:
    """Run the job file; ``temperature``, ``seed`` and ``stream`` (the flags), when given, replace the
    file's. Returns the exit code."""
    if out is not None and Path(out).suffix.lower() not in FORMATS:
        return _fail(f"--out: unknown format {Path(out).suffix!r} (known: {', '.join(FORMATS)})")
    if plot is not None and Path(plot).suffix.lower() != ".png":
        return _fail("--plot: give a .png path")
    if problem := _output_problem(out, plot):
        return _fail(problem)
    try:
        spec = with_thermal_options(read_spec(spec_path), temperature, seed, stream)
    except ValueError as error:
        return _fail(str(error))
    callback, close = _progress_bar(progress)
    try:
        model, q0, p0, options = job_arguments(spec)
        sol = _integrate_until_interrupted(model, q0, p0, callback, options)
    except ValueError as error:
        return _fail(f"{spec_path}: {error}")
    finally:
        close()
    provenance = sol.provenance or {}
    # the noise's temperature, seed and stream: what repeats this run (a seed drawn here is shown only here)
    thermal = {key: provenance[key] for key in THERMAL_KEYS if key in provenance}
    print(_summary_table({**sol.summary(), **thermal}))
    # A write that fails (a full disk) says so and goes on to the other output, with exit code 2: it was a
    # traceback and exit code 1, as if the run had stopped early, and the plot was not drawn.
    written = True
    if out is not None:
        written = _write(out, lambda: sol.save(out)) and written
    if plot is not None:
        def draw() -> None:
            import matplotlib

            matplotlib.use("Agg")
            ax = sol.plot.energy()
            ax.figure.savefig(plot, dpi=120)

        written = _write(plot, draw) and written
    if not written:
        return 2
    if not sol.success:
        print(f"raydamp run: stopped early ({sol.status}) at step {sol.failed_step or sol.steps}: {sol.message}",
              file=sys.stderr)
        return 1
    return 0


def _write(path: str, write) -> bool:
    """write(), then "wrote path"; False, with the reason on stderr, when it fails."""
    try:
        write()
    except OSError as error:
        print(f"raydamp run: could not write {path}: {error.strerror or error}", file=sys.stderr)
        return False
    print(f"wrote {path}")
    return True
