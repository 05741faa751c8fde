"""Package layout that pyproject.toml cannot express alone (its metadata lives there).

Every package and data folder under ``weavecap/`` is found automatically (namespace search,
so data folders such as ``estimate/weights`` count too); two top-level folders install inside
it: ``cli/`` as ``weavecap.cli`` (the commands, DESIGN.md's layout) and ``fixtures/`` as
``weavecap.fixtures`` (the inputs ``weavecap bench`` and the demos read, so that a wheel has
them too). What data each holds is declared in pyproject.toml's package-data.
"""

from setuptools import find_namespace_packages, setup

MAPPED = {"weavecap.cli": "cli", "weavecap.fixtures": "fixtures"}


def packages() -> list[str]:
    found = find_namespace_packages(include=["weavecap", "weavecap.*"], exclude=["*.__pycache__"])
    for name, folder in MAPPED.items():
        found += [name] + [f"{name}.{sub}" for sub in find_namespace_packages(where=folder, exclude=["*.__pycache__"])]
    return found


setup(packages=packages(), package_dir=MAPPED)
