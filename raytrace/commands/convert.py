"""`python -m raytrace convert SCENE -o OUT`: a Mitsuba 3 XML scene as raytrace's TOML (the scene table the XML
reader makes, raytrace/scene/mitsuba.py, so that rendering the TOML renders the XML, bit for bit), or a TOML
scene as Mitsuba 3 XML (raytrace/scene/mitsuba_writer.py). Files the scene names are written relative to the
output's folder; the outputs appear together or not at all (raytrace/outputs.py)."""
import os
from pathlib import Path

from ..errors import InputError
from ..outputs import Outputs

from ..scene.mitsuba import FILE_KEYS
from ..scene.toml_writer import scene_toml

TOML_HEADER = "# raytrace's scene format (docs/scene-format.md), converted from {source} by `raytrace convert`\n\n"


def relocated(table, scene_folder, out_folder):
    """`table` with its files (relative to `scene_folder`) relative to `out_folder`."""
    def moved(name):
        path = Path(scene_folder, name)
        return os.path.relpath(path, out_folder) if not Path(name).is_absolute() else name
    table = {**table, "shapes": [dict(s) for s in table.get("shapes", [])]}
    for shape in table["shapes"]:
        if "file" in shape:
            shape["file"] = moved(shape["file"])
    if "environment" in table and "filename" in table["environment"]:
        table["environment"] = {**table["environment"], "filename": moved(table["environment"]["filename"])}
    table["materials"] = {name: dict(m) for name, m in table.get("materials", {}).items()}
    for material in table["materials"].values():
        for key, value in list(material.items()):
            if isinstance(value, dict) and "filename" in value:  # a texture's table
                material[key] = {**value, "filename": moved(value["filename"])}
    if "emitters" in table:  # a spot's texture, a projector's image
        table["emitters"] = [{key: {**value, "filename": moved(value["filename"])}
                              if isinstance(value, dict) and "filename" in value else value
                              for key, value in light.items()} for light in table["emitters"]]
    assert set(FILE_KEYS) == {"shapes[].file", "environment.filename", "materials.NAME.PARAMETER.filename",
                              "emitters[].PARAMETER.filename"}
    return table


def convert(source, output, scene, translation=None):
    """Write `scene` (read from `source`; with the Translation of an XML source) to `output`: TOML from XML,
    XML from TOML."""
    source, output = Path(source), Path(output)
    from_xml = source.suffix.lower() == ".xml"
    wanted = ".toml" if from_xml else ".xml"
    if output.suffix.lower() != wanted:
        raise InputError("command line", "-o", str(output), f"must end in {wanted}: {source.name} is "
                         f"{'Mitsuba 3 XML' if from_xml else 'TOML'}, converted to {'TOML' if from_xml else 'XML'}")
    with Outputs(inputs=[source]) as outputs:
        main = outputs.reserve("-o", output)
        if from_xml:
            table = relocated(translation.table, source.parent, output.parent)
            files = {main: TOML_HEADER.format(source=source.name) + scene_toml(table)}
        else:
            from ..scene import mitsuba_writer
            text, extra = mitsuba_writer.to_xml(scene, output)
            files = {main: text}
            for name, data in extra.items():
                files[outputs.reserve("-o", output.parent / name)] = data
        for tmp, data in files.items():
            with outputs.writing(tmp):
                mode = "w" if isinstance(data, str) else "wb"
                with open(tmp, mode, **({"encoding": "utf-8"} if mode == "w" else {})) as f:
                    f.write(data)
        outputs.commit()
