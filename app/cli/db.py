"""`rehab db status` and `rehab db upgrade`: the registry as a whole, on SQLite or on a
department's PostgreSQL server (issue 32; app.records.registry.admin does the work).

Where the registry is comes from the registry URL file (app.records.registry.url), else the
data folder's SQLite registry (`--data-dir`, REHAB_DATA_DIR, the setting, the default). The
URL is printed with its password masked. Every refusal is one line with exit code 2.
"""

from __future__ import annotations

import argparse

from app.cli.common import EXIT_OK, CommandError, absolute, data_dir_for, subcommands
from app.records.registry.postgres import Roles


def add_db_commands(commands) -> None:
    parser = commands.add_parser(
        "db", help="the registry's engine, schema and seals; upgrade it",
        description="The registry as a whole: where it is (the registry URL file, else the "
                    "data folder's SQLite registry), its schema and its seals.")
    sub = subcommands(parser)
    status = sub.add_parser(
        "status", help="engine, place, schema version, rows per table, seals",
        description="Which engine and where (the password masked), the registry's schema "
                    "version and this console's, whether an upgrade is due, the rows of each "
                    "table, and whether every row matches its seal. Changes nothing.")
    status.set_defaults(func=cmd_status)
    upgrade = sub.add_parser(
        "upgrade", help="bring the registry to this console's schema",
        description="SQLite: migrate an older registry file (a copy of it is kept beside it "
                    "first). PostgreSQL: create the registry (tables, seals, numbering, the "
                    "clinic and research roles) in an empty database, with the database "
                    "owner's login. A registry newer than this console is refused.")
    defaults = Roles()
    upgrade.add_argument("--clinic-role", default=defaults.clinic,
                         help=f"PostgreSQL: the group role that sees names (default "
                              f"{defaults.clinic})")
    upgrade.add_argument("--research-role", default=defaults.research,
                         help=f"PostgreSQL: the group role that sees codes and data only "
                              f"(default {defaults.research})")
    upgrade.add_argument("--from", dest="source", metavar="FILE",
                         help="PostgreSQL: copy this SQLite registry (a registry.sqlite3, or "
                              "the data folder holding it) into the server's registry, which "
                              "must be empty; every row's seal is checked on arrival, and "
                              "nothing is copied unless all of it is")
    upgrade.set_defaults(func=cmd_upgrade)


def _location(args: argparse.Namespace):
    from app.records.registry.url import registry_url

    return registry_url(data_dir_for(args))


def cmd_status(args: argparse.Namespace) -> int:
    from app.records.registry import admin
    from app.records.registry.url import POSTGRESQL
    from app.records.station.waiting import waiting_line

    location = _location(args)
    if location.engine == POSTGRESQL:  # first: true whether the server answers or not
        waiting = waiting_line(data_dir_for(args))
        if waiting:
            print(waiting, flush=True)
    report = admin.status(location)
    for line in report.lines:
        print(line)
    if report.damaged:
        raise CommandError(report.damaged)
    return EXIT_OK


def cmd_upgrade(args: argparse.Namespace) -> int:
    from app.records.registry import admin

    roles = admin.check_roles(args.clinic_role, args.research_role)
    source = None
    if args.source is not None:
        if not args.source.strip():
            raise CommandError("--from is empty: give the SQLite registry to copy")
        source = absolute(args.source)
    print(admin.upgrade(_location(args), roles, source))
    return EXIT_OK
