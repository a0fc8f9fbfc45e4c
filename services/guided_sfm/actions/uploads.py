"""Check uploaded files before anything is stored: images verified by Pillow, zips read safely."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path, PurePosixPath
from typing import BinaryIO

import PIL.Image

from guided_sfm.actions.context import NewImage
from guided_sfm.errors import BadUpload, TooLarge

FORMATS = {"JPEG": (".jpg", ".jpeg"), "PNG": (".png",)}
EXIF_DATETIME_ORIGINAL, EXIF_IFD = 0x9003, 0x8769
CHUNK = 1 << 20


class Budget:
    """Bytes an upload may still write; raises TooLarge once spent (zip sizes can lie)."""

    def __init__(self, limit: int) -> None:
        self.limit, self.left = limit, limit

    def spend(self, amount: int, what: str) -> None:
        self.left -= amount
        if self.left < 0:
            raise TooLarge(f"{what}: the upload exceeds the limit of {self.limit // (1 << 20)} MB")


def copy_limited(source: BinaryIO, target: Path, budget: Budget, what: str) -> int:
    written = 0
    with open(target, "xb") as out:
        while chunk := source.read(CHUNK):
            budget.spend(len(chunk), what)
            out.write(chunk)
            written += len(chunk)
    return written


def safe_member(name: str) -> PurePosixPath:
    """A zip entry's path, refused when absolute or climbing out with '..'."""
    path = PurePosixPath(name.replace("\\", "/"))
    if path.is_absolute() or name.startswith(("/", "\\")) or ":" in path.parts[0] or ".." in path.parts:
        raise BadUpload(f"zip entry {name!r} has an absolute path or '..'; refused")
    return path


def zip_entries(archive: zipfile.ZipFile, budget: Budget) -> list[tuple[zipfile.ZipInfo, PurePosixPath]]:
    """The archive's files (not folders, not macOS metadata), checked before extracting any."""
    entries = [(info, safe_member(info.filename)) for info in archive.infolist()]
    files = [(i, p) for i, p in entries if not i.is_dir() and "__MACOSX" not in p.parts
             and not p.name.startswith(".")]
    total = sum(info.file_size for info, _ in files)
    if total > budget.left:
        raise TooLarge(f"the zip expands to {total / (1 << 20):.1f} MB, over the limit of "
                       f"{budget.limit // (1 << 20)} MB")
    return files


def extract(archive: zipfile.ZipFile, info: zipfile.ZipInfo, target: Path, budget: Budget) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    with archive.open(info) as source:
        copy_limited(source, target, budget, info.filename)


def open_zip(path: Path, shown: str) -> zipfile.ZipFile:
    """The zip at path, named in errors by the name it was uploaded as (never the temp file's)."""
    try:
        return zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise BadUpload(f"{shown}: not a readable zip file") from exc


def check_image(path: Path, name: str) -> NewImage:
    """Size and EXIF time of a JPEG/PNG file; BadUpload when it is anything else or corrupt."""
    try:
        with PIL.Image.open(path) as img:
            kind = img.format
            img.verify()
        with PIL.Image.open(path) as img:
            img.load()  # verify() misses truncated pixel data
            width, height = img.size
            taken = img.getexif().get_ifd(EXIF_IFD).get(EXIF_DATETIME_ORIGINAL)
    except (PIL.Image.UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        # Pillow's message may hold the staging path; the client sees only the name it sent.
        reason = str(exc).replace(str(path), name).replace(str(path.parent), "")
        raise BadUpload(f"{name}: not a readable JPEG or PNG image ({reason})") from exc
    if kind not in FORMATS:
        raise BadUpload(f"{name}: {kind} images are not accepted; upload JPEG or PNG")
    return NewImage(name, width, height, str(taken)[:32] if taken else None)


def image_name(raw: str, what: str) -> str:
    """The stored file name: the upload's base name, JPEG/PNG suffix required."""
    name = PurePosixPath(raw.replace("\\", "/")).name.strip()
    if not name or name.startswith(".") or len(name) > 200 or not name.isprintable():
        raise BadUpload(f"{what}: {raw!r} is not a usable image file name")
    if not name.lower().endswith(FORMATS["JPEG"] + FORMATS["PNG"]):
        raise BadUpload(f"{what}: {raw!r} is not a .jpg, .jpeg or .png file")
    return name


def stage_images(uploads: list[tuple[str, BinaryIO]], staging: Path, limit: int) -> list[NewImage]:
    """Copy (or unzip) the uploaded files into staging and check every image; nothing else is touched."""
    if not uploads:
        raise BadUpload("no files in the upload (multipart field 'files')")
    budget = Budget(limit)
    if any(name.lower().endswith(".zip") for name, _ in uploads):
        if len(uploads) != 1:
            raise BadUpload("upload either images or exactly one .zip of them, not both")
        raw = staging.parent / (staging.name + ".zip")
        copy_limited(uploads[0][1], raw, Budget(limit), uploads[0][0])
        try:
            return _unzip_images(raw, uploads[0][0], staging, budget)
        finally:
            raw.unlink(missing_ok=True)
    images = []
    for raw_name, source in uploads:
        name = image_name(raw_name, "upload")
        _claim(staging, name)
        if copy_limited(source, staging / name, budget, name) == 0:
            raise BadUpload(f"{name}: the file is empty")
        images.append(check_image(staging / name, name))
    return images


def _unzip_images(raw: Path, shown: str, staging: Path, budget: Budget) -> list[NewImage]:
    with open_zip(raw, PurePosixPath(shown.replace("\\", "/")).name) as archive:
        entries = zip_entries(archive, budget)
        if not entries:
            raise BadUpload("the zip holds no files")
        images = []
        for info, path in entries:
            name = image_name(path.name, "zip entry")
            _claim(staging, name)
            extract(archive, info, staging / name, budget)
            images.append(check_image(staging / name, name))
    return images


def _claim(staging: Path, name: str) -> None:
    if (staging / name).exists():
        raise BadUpload(f"{name} appears twice in the upload")


def discard(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)
