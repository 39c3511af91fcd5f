"""``drx model path|export|import``: where a model's files are, and DeepRacer-style packages."""

from pathlib import Path
from typing import Annotated

import typer

from drx.cli.output import console, emit, json_option

# The analysis modules (torch, pandas, onnx) load inside the commands, so `drx --help` does not pay.


@json_option
def path(name: Annotated[str, typer.Argument(help="The model's name.")]) -> None:
    """Print the model's folder (checkpoints and traces, laid out as deepracer-for-cloud does).

    Example:

      drx model path my-model
    """
    from drx.analysis.data import model_folder

    folder = model_folder(name)
    emit({"model": name, "path": str(folder)}, lambda: console.print(str(folder), soft_wrap=True))


@json_option
def export(
    name: Annotated[str, typer.Argument(help="The model's name.")],
    out: Annotated[Path, typer.Option("--out", help="The package to write (.tar.gz).")],
    checkpoint: Annotated[
        str, typer.Option("--checkpoint", help="best, last or an iteration number.")
    ] = "best",
    for_car: Annotated[
        bool,
        typer.Option(
            "--for-car",
            help="Write the package a physical DeepRacer car loads: model.pb (a TensorFlow frozen graph) "
            "and model_metadata.json. Upload it on the car's console or put it in models/ on a USB stick.",
        ),
    ] = False,
) -> None:
    """Export a model as a package: by default drx's own (model_metadata.json, reward_function.py,
    hyperparameters.json, the policy as ONNX and drx's checkpoint, for `drx model import` elsewhere);
    with --for-car the package a physical DeepRacer car races (see docs/CAR.md).

    Examples:

      drx model export my-model --for-car --out my-model.tar.gz

      drx model export my-model --out my-model-drx.tar.gz
    """
    if for_car:
        from drx.analysis.car_package import export_car

        path, summary = export_car(name, out, checkpoint)
        emit(
            summary,
            lambda: console.print(
                f"Wrote [bold]{path}[/] for the car: model.pb and model_metadata.json "
                f"(iteration {summary['checkpoint']['iteration']}, {checkpoint}); on the car it is named "
                f"{summary['car_model_name']!r}. See docs/CAR.md to load it."
            ),
        )
        return
    from drx.analysis.model_package import export_model

    path, manifest = export_model(name, out, checkpoint)
    cp = manifest["checkpoint"]
    data = {"path": str(path), "model": name, "checkpoint": cp, "files": sorted(manifest["files"])}
    emit(
        data,
        lambda: console.print(
            f"Exported [bold]{name}[/] (iteration {cp['iteration']}, {checkpoint}) to {path}: "
            + ", ".join(sorted(manifest["files"]))
        ),
    )


@json_option
def import_(
    file: Annotated[
        Path,
        typer.Argument(
            help="A package from `drx model export`, a DeepRacer model (.tar.gz with model.pb and "
            "model_metadata.json), or a model_metadata.json."
        ),
    ],
    name: Annotated[
        str | None, typer.Option("--name", help="Name here [default: the package's model name].")
    ] = None,
    track: Annotated[
        str | None,
        typer.Option("--track", help="For a DeepRacer model: the track it races by default [default: oval]."),
    ] = None,
    trust_reward: Annotated[
        bool,
        typer.Option(
            "--trust-reward",
            help="Run the package's reward function (to check it now and to train with it later); "
            "without it the code is stored and shown but never run.",
        ),
    ] = False,
) -> None:
    """Import a model package (registers its car, reward, track and model, ready to evaluate or clone),
    a DeepRacer model from the console, deepracer-for-cloud or a car (its model.pb runs through
    OpenVINO: `pip install openvino`; ready to evaluate), or a DeepRacer model_metadata.json (adds
    the matching car to the garage).

    Nothing in a package runs on import: the policy is read as weights only, and the reward
    function is stored but not run unless you give --trust-reward (training needs it; evaluation
    does not).

    Examples:

      drx model import my-model.tar.gz --name my-model-2

      drx model import carfile.tar.gz --name console-model --track reinvent_base

      drx model import model_metadata.json --name my-car
    """
    from drx.analysis.importer import ImportResult
    from drx.analysis.model_import import import_file
    from drx.services.garage import GarageEntry

    result = import_file(file, name, track, trust_reward)
    if isinstance(result, GarageEntry):
        v = result.vehicle
        emit(
            {"car": v.name, "vehicle": v.to_model_metadata()},
            lambda: console.print(f"Added car [bold]{v.name}[/] to the garage: {v.summary()}"),
        )
        return
    assert isinstance(result, ImportResult)

    def render() -> None:
        car = f"new car {result.car}" if result.car_created else f"car {result.car}"
        console.print(
            f"Imported model [bold]{result.model}[/] ({car}, track {result.track}, "
            f"checkpoint of iteration {result.checkpoint_iteration}); ready to evaluate or clone."
        )
        for note in result.notes:
            console.print(note)

    emit(result.to_dict(), render)


def register(model_app: typer.Typer) -> None:
    """Add ``path``, ``export`` and ``import`` to the ``drx model`` group."""
    model_app.command("path")(path)
    model_app.command("export")(export)
    model_app.command("import")(import_)
