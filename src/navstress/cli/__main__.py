"""``python -m navstress.cli``: the ``navstress`` command."""

from navstress.cli import main

main()
