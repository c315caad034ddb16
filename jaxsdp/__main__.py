"""`python -m jaxsdp ...`: the `jaxsdp` command line (see `jaxsdp._cli`)."""

from jaxsdp._cli import run

if __name__ == "__main__":
    run()
