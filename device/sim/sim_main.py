"""Entry point of the firmware under the `micropython` executable, on the simulation link.

    micropython -c "import sim_main; sim_main.run(root, lock_heap_in_isr, polled, costs)"

desktop/devicesim/runners.py starts it so. stdout is the link, so a
traceback goes to stderr, never to stdout.
"""

import sys


def run(root, lock_heap_in_isr=False, polled=False, costs=None):
    try:
        import app
        from hal_sim import Board
        from sim_link import PipeLink
        app.App(Board(PipeLink(), root, lock_heap_in_isr, polled, costs)).run()
    except BaseException as e:  # noqa: B036 - report anything, then exit non-zero
        if hasattr(sys, "print_exception"):   # MicroPython
            sys.print_exception(e, sys.stderr)
        else:                                 # CircuitPython has no sys.print_exception
            sys.stderr.write("%s: %s\n" % (e.__class__.__name__, e))
        sys.exit(1)
