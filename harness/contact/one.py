"""``python -m harness.contact.one ARGS``: one contact run in a process of its own (read the
pickled ``(args, out)``, write the run pickled to ``out``; an exception is the run's result)."""
import pickle
import sys


def main(path: str) -> None:
    from records.contact import ContactRun
    from records.trajectory import CRASHED

    from harness.contact.run import _step_in_worker

    with open(path, "rb") as fh:
        args, out = pickle.load(fh)
    try:
        run = _step_in_worker(*args)
    except Exception as exc:  # the engine's exception is the run's result
        run = ContactRun.failed(args[1], args[0], args[3], CRASHED, f"{type(exc).__name__}: {exc}")
    with open(out, "wb") as fh:
        pickle.dump(run, fh)


if __name__ == "__main__":
    main(sys.argv[1])
