"""The ``weavecap`` command line: click commands, one module each (installed as weavecap.cli)."""
