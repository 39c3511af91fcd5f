"""``drx info``: version, data home, database, schema revision and counts."""

from rich.table import Table

from drx.cli.output import console, emit, json_option
from drx.services.info import info as gather


@json_option
def info() -> None:
    """Show drx's version, data home, database, schema revision, what the registry holds and the device.

    The device is the one training picks here by default (auto), with torch's build.

    Example:

      DRX_HOME=/tmp/drx drx info --json
    """
    data = gather()

    def render() -> None:
        table = Table(show_header=False, title="drx")
        table.add_column(style="bold")
        table.add_column()
        table.add_row("version", data["version"])
        table.add_row("data home", data["data_home"])
        store = data["artifact_store"]
        table.add_row("artifacts", data["artifacts"])
        if store["kind"] != "local":
            table.add_row("artifact endpoint", store["endpoint"])
            table.add_row("artifact cache", store["local_folder"])
            table.add_row("artifact status", store["status"])
        table.add_row("database", data["database_url"])
        rev = data["schema_revision"]
        table.add_row(
            "schema revision",
            f"{rev}" + ("" if rev == data["schema_head"] else f" (code: {data['schema_head']})"),
        )
        device = data["device"]
        table.add_row("device (auto)", device["description"])
        if device["environment"]:
            table.add_row(
                "DRX_DEVICE", f"{device['environment']} (training jobs here; a job's --device beats it)"
            )
        sim = data["simulator"]
        table.add_row(
            "simulator",
            f"new models train on DeepRacer simulator {sim['new_models']}'s car "
            f"(cars: {', '.join(sim['cars'])}; `drx model create --simulator`)",
        )
        for key, value in data["counts"].items():
            table.add_row(key.replace("_", " "), str(value))
        console.print(table)

    emit(data, render)
