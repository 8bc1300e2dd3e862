"""fluxcal demo: the main job on its embedded default, no hardware needed."""

HELP = "simulated handheld: calibrate by hand rotation, then show |B| before/after"


def add_arguments(p):
    p.add_argument("--out", default="out", help="folder for plots (default out/)")
    p.add_argument("--seed", type=int, default=1, help="the virtual sensor (its errors)")
    p.add_argument("--core-only", action="store_true",
                   help="skip the firmware: fit a simulated hand rotation with the shared/ core and the references")


def run(args):
    if args.core_only:
        from desktop.demo.core import run_core_demo
        return run_core_demo(seed=args.seed)
    from desktop.demo.handheld import run as run_handheld
    return run_handheld(out_dir=args.out, seed=args.seed)
