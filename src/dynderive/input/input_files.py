"""The files a robot file reads: itself, an MJCF file's ``<include>``s and the asset files it
names (meshes, height fields, skins, textures), a URDF's mesh files. A command that writes a
file (``import -o``, ``simulate --plot``) refuses to write over any of them, so that it never
breaks the model it read. The scan only reads the XML's elements (no entities, no MuJoCo);
files it cannot read are left to the reader to report."""

from __future__ import annotations

from pathlib import Path
from urllib.parse import unquote

from ..errors import InputError
from .loader import read_text
from .mjcf_positions import MAX_INCLUDE_DEPTH, Locator

#: MJCF elements and the attributes that name a file, with the ``<compiler>`` folder they are
#: read from (``assetdir`` stands in for both).
_MJCF_FILES = {"mesh": ("meshdir", ("file",)), "hfield": ("meshdir", ("file",)), "skin": ("meshdir", ("file",)),
               "texture": ("texturedir", ("file", "fileright", "fileleft", "fileup", "filedown", "filefront",
                                          "fileback"))}


def input_files(path: Path) -> tuple[Path, ...]:
    """``path`` and the files it reads (those named, whether they exist or not)."""
    if path.suffix.lower() not in (".xml", ".urdf") or not path.is_file():
        return (path,)
    locator = _locator(path, path.parent)
    if locator is None or not locator.elements:
        return (path,)
    if locator.elements[0][0] == "robot":
        return (path, *_urdf_meshes(locator, path))
    return (path, *_mjcf_files(locator, path.parent))


def _locator(path: Path, base: Path) -> Locator | None:
    try:
        return Locator(read_text(path), path, base)   # a FIFO or a device is not opened
    except InputError:
        return None


def _urdf_meshes(locator: Locator, path: Path) -> list[Path]:
    """``<mesh filename>``: relative to the URDF's folder, ``file://`` paths, and ``package://P/rest``
    as ``rest`` under the nearest folder called ``P`` above the URDF (where a ROS workspace has it)."""
    found = []
    for tag, attributes, _ in locator.elements:
        name = attributes.get("filename") if tag == "mesh" else None
        if not name:
            continue
        if name.startswith("file://"):
            found.append(Path(unquote(name[len("file://"):])))
        elif name.startswith("package://"):
            package, _, rest = name[len("package://"):].partition("/")
            found += [folder / rest for folder in path.resolve().parents if folder.name == package][:1]
        elif "://" not in name:
            found.append(path.parent / name)
    return found


def _mjcf_files(locator: Locator, base: Path) -> list[Path]:
    """Every ``<include>`` (followed ``MAX_INCLUDE_DEPTH`` deep, relative to the main file's
    folder as MuJoCo reads them) and the asset files of the main file and its includes."""
    files: list[Path] = []
    seen = {locator.path.resolve()} if locator.path is not None else set()
    frontier, locators = [locator], [locator]
    for _ in range(MAX_INCLUDE_DEPTH):
        nested = []
        for current in frontier:
            for file, _ in current.included():
                files.append(file)
                key = file.resolve()
                if key in seen or not file.is_file():
                    continue
                seen.add(key)
                inner = _locator(file, base)
                nested += [inner] if inner is not None else []
        locators += nested
        frontier = nested
        if not frontier:
            break
    elements = [element for current in locators for element in current.elements]
    folders = {"meshdir": base, "texturedir": base}
    for tag, attributes, _ in elements:
        if tag == "compiler":
            asset = attributes.get("assetdir")
            for key in folders:
                if attributes.get(key) or asset:
                    folders[key] = base / (attributes.get(key) or asset)
    for tag, attributes, _ in elements:
        if tag in _MJCF_FILES:
            folder, keys = _MJCF_FILES[tag]
            files += [folders[folder] / attributes[key] for key in keys if attributes.get(key)]
        elif tag == "model" and attributes.get("file"):
            files.append(base / attributes["file"])
    return files
