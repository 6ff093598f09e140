"""``rftfem collect``: one table row per run folder (placeholder, being written)."""

DESCRIPTION = "Tabulate run folders."


def add_arguments(parser):
    parser.add_argument("dirs", nargs="+", metavar="DIR")


def main(args, console) -> int:
    raise NotImplementedError
