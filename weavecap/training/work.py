"""A training run's work folder: its data shards and checkpoints belong to one set of settings."""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import InputError


def claim_work_folder(work: Path, plan: dict, *, name: str = "config.json") -> None:
    """Make ``work`` hold the data of ``plan`` (a dict of settings, recorded in ``work/name``):
    refuse, naming the file, a folder that holds data made with other settings.

    Raises
    ------
    InputError
        ``work/name`` records other settings (use another ``--work`` folder, or delete it).
    """
    work = Path(work)
    plan_file = work / name
    if plan_file.is_file() and json.loads(plan_file.read_text()) != json.loads(json.dumps(plan)):
        raise InputError(f"{work}: holds data or a checkpoint made with other settings ({plan_file}); use another "
                         "--work folder or delete that one")
    work.mkdir(parents=True, exist_ok=True)
    plan_file.write_text(json.dumps(plan, indent=1) + "\n")
