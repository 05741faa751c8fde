"""Man pages generated from the click commands: ``man/weavecap.1`` and ``man/weavecap-CMD.1``.

Run ``python -m weavecap.cli.manpages man`` (``make man``) after changing a command's help or
options; ``tests/test_manpages.py`` fails while ``man/`` is stale. The pages are a pure function
of the click command tree and the package version (no dates), so regenerating is a no-op when
nothing changed.

Each page has NAME, SYNOPSIS, DESCRIPTION, OPTIONS, EXIT STATUS, EXAMPLES (the help's
``Examples:`` block) and SEE ALSO. Commands whose module is not installed are left out.
"""

from __future__ import annotations

import inspect
import sys
from pathlib import Path

import click

from weavecap import __version__
from weavecap.cli.main import COMMANDS, cli

EXIT_STATUS = [
    ("0", "Everything asked for was done."),
    ("1", "Something unexpected went wrong (set WEAVECAP_DEBUG=1 to see the traceback)."),
    ("2", "Bad usage or an invalid input file: bad JSON, a value out of range (the message names the "
          "field and the allowed range), a missing file, an output that exists without --force, an "
          "output that cannot be written, an output folder another run holds, a missing requirement "
          "(libLLVM 19 or newer)."),
    ("3", "A photo was rejected: not readable, not an image weavecap reads, not a woven fabric, or yarns "
          "not resolvable."),
    ("130", "Interrupted by Ctrl-C (143: by SIGTERM); finished outputs are kept."),
]


def escape(text: str) -> str:
    """Text safe for roff: backslashes escaped, no line starting with a control character."""
    lines = text.replace("\\", "\\e").replace("-", "\\-").split("\n")
    return "\n".join("\\&" + line if line.startswith((".", "'")) else line for line in lines)


def split_help(help_text: str) -> tuple[list[tuple[bool, str]], list[str]]:
    """A command's help as (literal?, paragraph) pairs, and the lines of its Examples block.

    Paragraphs are separated by blank lines; click's ``\\b`` marks one that must not be rewrapped.
    """
    paragraphs, examples = [], []
    for block in inspect.cleandoc(help_text).split("\n\n"):
        literal = block.startswith("\b")
        lines = [line for line in block.split("\n") if line != "\b"]
        if literal and lines and lines[0].strip() == "Examples:":
            examples += [line.strip() for line in lines[1:] if line.strip()]
        elif literal:
            paragraphs.append((True, "\n".join(lines)))
        else:
            paragraphs.append((False, " ".join(line.strip() for line in lines)))
    return paragraphs, examples


def page(command: click.Command, ctx: click.Context, *, see_also: list[str], subcommands=()) -> str:
    """The roff source of one man page."""
    name = ctx.command_path.replace(" ", "-")
    paragraphs, examples = split_help(command.help or "")
    out = [f'.TH {name.upper()} 1 "" "weavecap {__version__}" "weavecap manual"',
           ".SH NAME", f"{escape(name)} \\- {escape(command.get_short_help_str(limit=200))}",
           ".SH SYNOPSIS", f".B {escape(ctx.command_path)}",
           escape(" ".join(command.collect_usage_pieces(ctx))), ".SH DESCRIPTION"]
    for literal, text in paragraphs:
        out += [".PP", ".nf", escape(text), ".fi"] if literal else [".PP", escape(text)]
    if subcommands:
        out.append(".SH COMMANDS")
        for sub_name, sub in subcommands:
            out += [".TP", f".B {escape(sub_name)}", escape(sub.get_short_help_str(limit=200)),
                    f"See \\fB{escape(name)}\\-{escape(sub_name)}\\fR(1)."]
    out.append(".SH OPTIONS")
    for param in command.get_params(ctx):
        record = param.get_help_record(ctx) if isinstance(param, click.Option) else None
        if record is not None:
            out += [".TP", f".B {escape(record[0])}", escape(record[1])]
    out.append(".SH EXIT STATUS")
    for code, meaning in EXIT_STATUS:
        out += [".TP", f".B {code}", escape(meaning)]
    if examples:
        out += [".SH EXAMPLES", ".nf", escape("\n".join(examples)), ".fi"]
    out += [".SH SEE ALSO", ",\n".join(f".BR {escape(p)} (1)" for p in see_also)]
    return "\n".join(out) + "\n"


def generate() -> dict[str, str]:
    """File name → roff source, for ``weavecap`` and every command that loads."""
    root = click.Context(cli, info_name="weavecap", **cli.context_settings)
    commands = [(n, c) for n in sorted(COMMANDS) if (c := cli.get_command(root, n)) is not None]
    names = [f"weavecap-{n}" for n, _ in commands]
    pages = {"weavecap.1": page(cli, root, see_also=names, subcommands=commands)}
    for sub_name, sub in commands:
        ctx = click.Context(sub, info_name=sub_name, parent=root, **sub.context_settings)
        others = ["weavecap"] + [n for n in names if n != f"weavecap-{sub_name}"]
        pages[f"weavecap-{sub_name}.1"] = page(sub, ctx, see_also=others)
    return pages


def write(folder: Path) -> list[Path]:
    """Write the pages into ``folder`` and delete pages of commands that no longer exist."""
    folder.mkdir(parents=True, exist_ok=True)
    pages = generate()
    for stale in folder.glob("weavecap*.1"):
        if stale.name not in pages:
            stale.unlink()
    written = []
    for name, text in pages.items():
        path = folder / name
        path.write_text(text, encoding="utf-8")
        written.append(path)
    return written


def main(argv: list[str] | None = None) -> None:
    """``python -m weavecap.cli.manpages [FOLDER]`` (default ``man``)."""
    args = sys.argv[1:] if argv is None else argv
    for path in write(Path(args[0] if args else "man")):
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
