"""``drx model path|export|import``: where a model's files are, and DeepRacer-style packages."""

from pathlib import Path
from typing import Annotated, Any

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
    out: Annotated[
        str,
        typer.Option(
            "--out", help="The package to write (.tar.gz); --for-deepracer: a folder, a .tar.gz or s3://bucket/prefix."
        ),
    ],
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
    for_deepracer: Annotated[
        bool,
        typer.Option(
            "--for-deepracer",
            help="Write DeepRacer's model folder (a folder, a .tar.gz or s3://bucket/prefix) that "
            "deepracer-for-cloud takes as a pretrained model and DeepRacer on AWS imports; a compact "
            "model is distilled into DeepRacer's shallow network first (docs/DEEPRACER.md).",
        ),
    ] = False,
    laps: Annotated[
        int,
        typer.Option("--laps", min=0, max=10, help="--for-deepracer: laps raced by the original and the "
                     "export, to compare them (0: none)."),
    ] = 3,
    seed: Annotated[
        int, typer.Option("--seed", help="--for-deepracer: the races' and the distillation's seed.")
    ] = 0,
    distill_minutes: Annotated[
        float,
        typer.Option("--distill-minutes", min=0.1, max=60.0, help="--for-deepracer: the longest a compact "
                     "model's distillation into the shallow network may take."),
    ] = 5.0,
) -> None:
    """Export a model as a package: by default drx's own (model_metadata.json, reward_function.py,
    hyperparameters.json, the policy as ONNX and drx's checkpoint, for `drx model import` elsewhere);
    with --for-car the package a physical DeepRacer car races (see docs/CAR.md); with
    --for-deepracer DeepRacer's model folder, for deepracer-for-cloud and DeepRacer on AWS
    (see docs/DEEPRACER.md).

    Examples:

      drx model export my-model --for-car --out my-model.tar.gz

      drx model export my-model --for-deepracer --out my-model/

      drx model export my-model --out my-model-drx.tar.gz
    """
    if for_car and for_deepracer:
        from drx.errors import DrxError

        raise DrxError("--for-car and --for-deepracer write different packages; give one of them.")
    if for_deepracer:
        _export_deepracer(name, out, checkpoint, laps, seed, distill_minutes)
        return
    if for_car:
        from drx.interchange.car.car_package import export_car

        path, summary = export_car(name, Path(out), checkpoint)
        emit(
            summary,
            lambda: console.print(
                f"Wrote [bold]{path}[/] for the car: model.pb and model_metadata.json "
                f"(iteration {summary['checkpoint']['iteration']}, {checkpoint}); on the car it is named "
                f"{summary['car_model_name']!r}. See docs/CAR.md to load it."
            ),
        )
        return
    from drx.interchange.package.model_package import export_model

    path, manifest = export_model(name, Path(out), checkpoint)
    cp = manifest["checkpoint"]
    data = {"path": str(path), "model": name, "checkpoint": cp, "files": sorted(manifest["files"])}
    emit(
        data,
        lambda: console.print(
            f"Exported [bold]{name}[/] (iteration {cp['iteration']}, {checkpoint}) to {path}: "
            + ", ".join(sorted(manifest["files"]))
        ),
    )


def _export_deepracer(name: str, out: str, checkpoint: str, laps: int, seed: int, minutes: float) -> None:
    from drx.cli.output import steps
    from drx.evaluate.course import TimeTrialCourse
    from drx.interchange.deepracer.export import export_deepracer

    with steps(f"Exporting {name} for DeepRacer") as say:
        result = export_deepracer(
            name,
            out,
            checkpoint,
            course_for=TimeTrialCourse.for_model,
            seed=seed,
            laps=laps,
            distill_seconds=minutes * 60.0,
            on_progress=say,
        )

    def render() -> None:
        mb = result.size_bytes / 1e6
        console.print(
            f"Wrote DeepRacer's model folder of [bold]{name}[/] to {result.destination}: checkpoint "
            f"{result.checkpoint} (iteration {result.iteration}, {checkpoint}), {len(result.files)} files, "
            f"{mb:.1f} MB, in {result.seconds:.0f} s."
        )
        if result.distillation:
            d = result.distillation
            console.print(
                f"Distilled the {result.network} network into DeepRacer's shallow network: the most probable "
                f"action agrees on {100 * d['agreement']:.1f}% of held-out frames ({d['frames']} frames, "
                f"{d['seconds']:.0f} s)."
            )
        for label, laps_ in (("original", result.original), ("export", result.exported)):
            if laps_ is not None:
                fastest = f"fastest {laps_.fastest:.2f} s" if laps_.fastest is not None else "no lap"
                console.print(
                    f"  {label:8} {laps_.completed}/{laps_.laps} laps, {fastest}, {laps_.off_track} off-track"
                )
        for note_text in result.notes:
            console.print(note_text)

    emit(result.to_dict(), render)


@json_option
def import_(
    file: Annotated[
        str,
        typer.Argument(
            help="DeepRacer's model folder (a folder, its .tar.gz or s3://bucket/prefix), a package from "
            "`drx model export`, a DeepRacer car model (.tar.gz with model.pb), or a model_metadata.json."
        ),
    ],
    name: Annotated[
        str | None, typer.Option("--name", help="Name here [default: the package's model name].")
    ] = None,
    track: Annotated[
        str | None,
        typer.Option(
            "--track",
            help="For a DeepRacer model: the track it races (and trains) on [default: its "
            "training_params.yaml's; a car model.pb: oval].",
        ),
    ] = None,
    checkpoint: Annotated[
        str,
        typer.Option(
            "--checkpoint", help="DeepRacer's model folder: best, last or a checkpoint name N_Step-M."
        ),
    ] = "best",
    trust_reward: Annotated[
        bool,
        typer.Option(
            "--trust-reward",
            help="Run the package's reward function (to check it now and to train with it later); "
            "without it the code is stored and shown but never run.",
        ),
    ] = False,
) -> None:
    """Import DeepRacer's model folder (deepracer-for-cloud, DeepRacer on AWS, the console: ready to
    evaluate, clone and train on), a model package (registers its car, reward, track and model,
    ready to evaluate or clone), a DeepRacer car model (its model.pb runs through OpenVINO: `pip
    install openvino`; ready to evaluate), or a DeepRacer model_metadata.json (adds the matching car
    to the garage).

    Nothing in a package runs on import: the policy is read as weights only, and the reward
    function is stored but not run unless you give --trust-reward (training needs it; evaluation
    does not).

    Examples:

      drx model import ./my-drfc-model/ --name from-drfc --trust-reward

      drx model import s3://bucket/rl-deepracer-sagemaker --checkpoint last

      drx model import my-model.tar.gz --name my-model-2

      drx model import carfile.tar.gz --name console-model --track reinvent_base

      drx model import model_metadata.json --name my-car
    """
    from drx.interchange.deepracer.locations import is_model_source
    from drx.interchange.importers.importer import ImportResult
    from drx.interchange.importers.model_import import import_file
    from drx.services.garage import GarageEntry

    if is_model_source(file):
        _import_folder(file, name, track, checkpoint, trust_reward)
        return
    if checkpoint != "best":
        from drx.errors import DrxError

        raise DrxError("--checkpoint applies to DeepRacer's model folder; this file holds one model.")
    result = import_file(Path(file), name, track, trust_reward)
    if isinstance(result, GarageEntry):
        v = result.vehicle
        emit(
            {"car": v.name, "vehicle": v.to_model_metadata()},
            lambda: console.print(f"Added car [bold]{v.name}[/] to the garage: {v.summary()}"),
        )
        return
    assert isinstance(result, ImportResult)
    what = f"checkpoint of iteration {result.checkpoint_iteration}); ready to evaluate or clone."
    _emit_import(result, "model", what)


def _import_folder(source: str, name: str | None, track: str | None, checkpoint: str, trust: bool) -> None:
    from drx.interchange.deepracer.folder_import import import_folder

    result = import_folder(source, name, track, checkpoint, trust)
    what = f"checkpoint {result.checkpoint}, DeepRacer's two towers); ready to evaluate, clone and train."
    _emit_import(result, "DeepRacer model", what)


def _emit_import(result: Any, kind: str, what: str) -> None:
    """Say what an import registered (its car, track and checkpoint ``what``) and its notes."""

    def render() -> None:
        car = f"new car {result.car}" if result.car_created else f"car {result.car}"
        console.print(f"Imported {kind} [bold]{result.model}[/] ({car}, track {result.track}, {what}")
        for note_text in result.notes:
            console.print(note_text)

    emit(result.to_dict(), render)


def register(model_app: typer.Typer) -> None:
    """Add ``path``, ``export`` and ``import`` to the ``drx model`` group."""
    model_app.command("path")(path)
    model_app.command("export")(export)
    model_app.command("import")(import_)
