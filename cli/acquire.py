"""contactlab acquire: record trials from the simulator or the hardware into an archive."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

import click

from contactlab.cli.common import count, echo_json, json_option, quiet_option
from contactlab.cli.inputs import check_inputs
from contactlab.fileio import check_not_input


@click.command()
@click.option("--source", type=click.Choice(["sim", "netft", "phantom"]), default="sim",
              show_default=True, help="Where the trials come from.")
@click.option("--spec", "spec_name", default=None, metavar="SPEC",
              help="Dataset spec (--source sim): a name in datasets_spec/ such as stroke-a, "
                   "or a path to a .toml file. --list-specs shows the names.")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="The archive to write.")
@click.option("--trials", "n_trials", type=click.IntRange(min=1), default=None,
              help="Number of trials [default: the spec's count; 1 for hardware].")
@click.option("--seed", type=int, default=1, show_default=True,
              help="Run seed: trial k is simulated from a seed derived from (seed, k).")
@click.option("--append", is_flag=True,
              help="Add the trials to an existing archive (new trial ids; atomic).")
@click.option("--force", is_flag=True, help="Replace an existing archive.")
@click.option("--host", default=None, help="Net F/T sensor address (--source netft).")
@click.option("--port", type=click.IntRange(1, 65535), default=49152, show_default=True,
              help="Net F/T RDT port (--source netft).")
@click.option("--duration", "duration_s", type=click.FloatRange(min=0.0, min_open=True),
              default=None, help="Seconds per trial (--source netft / phantom).")
@click.option("--rate", "rate_hz", type=click.FloatRange(min=0.0, min_open=True),
              default=1000.0, show_default=True, help="Sample rate of a hardware source, Hz.")
@click.option("--list-specs", is_flag=True, help="List the dataset specs and exit.")
@json_option
@quiet_option
def acquire(source, spec_name, out, n_trials, seed, append, force, host, port, duration_s,
            rate_hz, list_specs, as_json, quiet):
    """Record trials into an archive: simulated from a dataset spec, or from hardware.

    Each trial is written as soon as it is complete, so an interrupted run
    leaves every finished trial in a valid archive: Ctrl-C or SIGTERM drops
    the trial in progress and says what was kept, a second one quits at once,
    and after a SIGKILL the next command
    on the archive returns it to its last finished trial. The
    same --seed gives the same trials, and --trials 3 gives the first three
    trials of --trials 8. An existing archive is never replaced without
    --force; --append adds trials to it.

    \b
    Examples:
      contactlab acquire --spec stroke-a --out strokes.h5
      contactlab acquire --spec hf-train --out hf.h5 --seed 7
      contactlab acquire --spec stroke-a --out strokes.h5 --append --trials 2
      contactlab acquire --spec my-spec.toml --out mine.h5 --trials 3 --json
      contactlab acquire --source netft --host 192.168.1.1 --duration 10 --out ft.h5
      contactlab acquire --source phantom --duration 5 --out ph.h5
      contactlab acquire --list-specs
    """
    from contactlab.acquire.record import record
    from contactlab.acquire.spec import list_specs as spec_names
    from contactlab.acquire.spec import load_spec

    if list_specs:
        specs = [load_spec(n) for n in spec_names()]
        if as_json:
            echo_json({"specs": [{"name": s.name, "title": s.title, "thesis": s.thesis,
                                  "trials": s.n_trials, "status": s.status} for s in specs]})
        else:
            for s in specs:
                state = "" if s.ready else f"  [{s.status}]"
                click.echo(f"{s.name:22s} {s.n_trials:3d} trials  {s.thesis:8s} {s.title}{state}")
        return
    if out is None:
        raise click.UsageError("missing option '--out'")
    if spec_name is not None and Path(spec_name).is_file():
        check_not_input(out, [spec_name], option="--out")
    if append and out.exists():
        check_inputs([out])  # never append to (and so rewrite) an archive that does not conform
    spec = None
    if source == "sim":
        if spec_name is None:
            raise click.UsageError("--source sim needs --spec NAME; --list-specs lists the names")
        for name, value in (("--host", host), ("--duration", duration_s)):
            if value is not None:
                raise click.UsageError(f"{name} is for hardware sources, not --source sim")
        spec = load_spec(spec_name)
        first = _next_index(out, spec.name) if append else 0
        from contactlab.acquire.sim import SimSource

        src = SimSource(spec, first=first)
        n = n_trials or spec.n_trials
        title = f"{spec.title} (simulated; spec {spec.name}, thesis {spec.thesis})"
    else:
        if spec_name is not None:
            raise click.UsageError(f"--spec is for --source sim, not --source {source}")
        if duration_s is None:
            raise click.UsageError(f"--source {source} needs --duration")
        prefix = source if not append else \
            f"{source}-{datetime.now(timezone.utc).strftime('%Y%m%dT%H%M%S')}-"
        if source == "netft":
            if host is None:
                raise click.UsageError("--source netft needs --host")
            from contactlab.acquire.netft import NetFTSource

            src = NetFTSource(host=host, port=port, duration_s=duration_s, rate_hz=rate_hz,
                              trial_prefix=prefix)
            title = f"Net F/T recording from {host}"
        else:
            from contactlab.acquire.phantom import PhantomSource

            src = PhantomSource(duration_s=duration_s, rate_hz=rate_hz, trial_prefix=prefix)
            title = "PHANToM recording"
        n = n_trials or 1
    summary = record(src, out=out, n_trials=n, seed=seed, append=append, force=force,
                     title=title, quiet=quiet or as_json)
    summary["spec"] = None if spec is None else spec.name
    if as_json:
        echo_json(summary)
    else:
        click.echo(f"{out}: {count(summary['trials_written'], 'trial')} written "
                   f"({', '.join(summary['trial_ids'])}), seed {seed}")


def _next_index(out: Path, spec_name: str) -> int:
    """The index after the last ``<spec>-NNN`` trial in the archive ``out`` (0 if none)."""
    from contactlab.archive import open_archive

    if not out.exists():
        return 0
    with open_archive(out) as archive:
        ids = list(archive.trial_ids)
    taken = [int(t[len(spec_name) + 1:]) for t in ids
             if t.startswith(spec_name + "-") and t[len(spec_name) + 1:].isdigit()]
    return max(taken) + 1 if taken else 0
