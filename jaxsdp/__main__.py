"""`python -m jaxsdp ...`: the `jaxsdp` command line (see `jaxsdp._cli`)."""

from jaxsdp._cli import main

if __name__ == "__main__":
    raise SystemExit(main())
