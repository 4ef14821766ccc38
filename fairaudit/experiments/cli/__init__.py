"""The plug-in's commands, ``fairaudit experiment`` and ``fairaudit prepare-model``: one module each.

Each is an entry point of the group ``fairaudit.commands`` (pyproject.toml): the ``fairaudit`` command loads it,
calls its ``add_parser(subparsers)``, which adds the command with ``set_defaults(func=run)``, and runs
``run(args) -> int`` as it runs its own commands (docs/design.md, "The plug-in interface").
"""
