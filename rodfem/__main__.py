"""``rodfem`` (the console script) and ``python -m rodfem``: the signal handlers first, before
anything heavy is imported, so that Ctrl-C or SIGTERM at any point of start-up is one line."""

import sys


def main() -> int:
    from rodfem.output import interrupts

    interrupts.install()
    try:
        from rodfem.cli import main as cli
    except Exception as err:  # noqa: BLE001 (a signal during the imports, or what it became)
        signum = interrupts.signal_behind(err)
        if signum is None:
            raise
        print(f"rodfem: {interrupts.Interrupted(signum)}; stopped during start-up, nothing "
              "written", file=sys.stderr)
        return 128 + signum
    return cli()


if __name__ == "__main__":
    sys.exit(main())
