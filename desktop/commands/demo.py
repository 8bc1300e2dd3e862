"""fluxcal demo: the main job on its embedded default, no hardware needed."""

from desktop.errors import CommandError

HELP = "simulated handheld: calibrate by hand rotation, then show |B| before/after"


def add_arguments(p):
    p.add_argument("--out", default="out", help="folder for plots (default out/)")
    p.add_argument("--seed", type=int, default=1, help="the virtual sensor")
    p.add_argument("--core-only", action="store_true",
                   help="skip the firmware: fit a simulated hand rotation with the shared/ core and the references")


def run(args):
    if not args.core_only:
        try:
            from desktop.devicesim import demo as device_demo
        except ImportError:
            device_demo = None
        if device_demo is not None and hasattr(device_demo, "run"):
            return device_demo.run(out_dir=args.out)
        print("(firmware simulation not available: running the calibration core only)")
    from desktop.core_demo import run_core_demo

    try:
        return run_core_demo(seed=args.seed)
    except ValueError as exc:
        raise CommandError(str(exc))
