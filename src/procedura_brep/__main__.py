"""``python -m procedura_brep``: the command line (the same as ``procedura-brep``)."""

from .cli import main

main()
