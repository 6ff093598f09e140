"""``rftfem render`` options (placeholder, being written)."""

DESCRIPTION = "Draw a finished run."


def add_arguments(parser):
    parser.add_argument("results", metavar="RESULTS_DIR")


def main(args, console) -> int:
    raise NotImplementedError
