"""Check uploaded files before anything is stored: images verified by Pillow, zips read safely."""

from __future__ import annotations

import dataclasses
import hashlib
import re
import shutil
import zipfile
from pathlib import Path, PurePosixPath
from typing import BinaryIO

import PIL.Image

from guided_sfm.actions.context import NewImage
from guided_sfm.errors import BadUpload, TooLarge
from guided_sfm.settings import PREFIX

FORMATS = {"JPEG": (".jpg", ".jpeg"), "PNG": (".png",)}
EXIF_DATETIME_ORIGINAL, EXIF_IFD = 0x9003, 0x8769
CHUNK = 1 << 20
THUMBNAIL_SIZE = (256, 256)
THUMBS = ".thumbs"  # a staging folder no image name can take (names never start with a dot)


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


def check_image(path: Path, name: str, max_mpx: int | None = None, thumbnail: Path | None = None) -> NewImage:
    """Size and EXIF time of a JPEG/PNG file; BadUpload when it is anything else, corrupt or over
    `max_mpx` megapixels (read from the header, before any decode). With `thumbnail`, the preview
    is written from the same read, JPEGs decoded at the smallest scale it needs."""
    try:
        with PIL.Image.open(path) as img:
            kind, (width, height) = img.format, img.size
            _check_pixels(name, width, height, max_mpx)
            img.verify()
        with PIL.Image.open(path) as img:
            img.draft("RGB", THUMBNAIL_SIZE)  # JPEG: decode at 1/2..1/8 scale; the check still reads it all
            img.load()  # verify() misses truncated pixel data
            taken = img.getexif().get_ifd(EXIF_IFD).get(EXIF_DATETIME_ORIGINAL)
            if thumbnail is not None:
                save_thumbnail(img, thumbnail)
    except PIL.Image.DecompressionBombError as exc:  # beyond Pillow's own cap: its header says so
        raise BadUpload(f"{name}: {_pixels_named(exc)} pixels, over the limit of {max_mpx or '?'} Mpx "
                        f"({PREFIX}MAX_IMAGE_MPX); refused before decoding") from exc
    except (PIL.Image.UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        # Pillow's message may hold the staging path; the client sees only the name it sent.
        reason = str(exc).replace(str(path), name).replace(str(path.parent), "")
        raise BadUpload(f"{name}: not a readable JPEG or PNG image ({reason})") from exc
    if kind not in FORMATS:
        raise BadUpload(f"{name}: {kind} images are not accepted; upload JPEG or PNG")
    return NewImage(name, width, height, str(taken)[:32] if taken else None)


def _check_pixels(name: str, width: int, height: int, max_mpx: int | None) -> None:
    if max_mpx is not None and width * height > max_mpx * 1_000_000:
        raise BadUpload(f"{name}: {width} x {height} = {width * height / 1e6:.1f} Mpx, over the limit "
                        f"of {max_mpx} Mpx ({PREFIX}MAX_IMAGE_MPX); refused before decoding")


def _pixels_named(exc: Exception) -> str:
    """The pixel count in Pillow's message ('Image size (N pixels) exceeds ...') in Mpx."""
    found = re.search(r"\((\d+) pixels\)", str(exc))
    return f"{int(found.group(1)) / 1e6:.1f} Mpx" if found else "too many"


def save_thumbnail(img: PIL.Image.Image, target: Path) -> None:
    """A small JPEG preview (JPEG rather than PNG: see the Pillow/pycolmap pitfall in cli.py)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    img.thumbnail(THUMBNAIL_SIZE)
    img.convert("RGB").save(target, "JPEG", quality=85)


def image_name(raw: str, what: str) -> str:
    """The stored file name: the upload's base name, JPEG/PNG suffix required."""
    name = PurePosixPath(raw.replace("\\", "/")).name.strip()
    # bytes, not characters: file systems cap a name at 255 bytes, and UTF-8 takes up to 4 a character
    if not name or name.startswith(".") or len(name.encode()) > 200 or not name.isprintable():
        raise BadUpload(f"{what}: {raw!r} is not a usable image file name")
    if not name.lower().endswith(FORMATS["JPEG"] + FORMATS["PNG"]):
        raise BadUpload(f"{what}: {raw!r} is not a .jpg, .jpeg or .png file")
    return name


def stage_images(uploads: list[tuple[str, BinaryIO]], staging: Path, limit: int,
                 max_mpx: int | None = None) -> list[NewImage]:
    """Copy (or unzip) the uploaded files into staging, check every image and write its thumbnail
    to staging/.thumbs/; nothing else is touched."""
    if not uploads:
        raise BadUpload("no files in the upload (multipart field 'files')")
    budget = Budget(limit)
    if any(name.lower().endswith(".zip") for name, _ in uploads):
        if len(uploads) != 1:
            raise BadUpload("upload either images or exactly one .zip of them, not both")
        raw = staging.parent / (staging.name + ".zip")
        copy_limited(uploads[0][1], raw, Budget(limit), uploads[0][0])
        try:
            return _unzip_images(raw, uploads[0][0], staging, budget, max_mpx)
        finally:
            raw.unlink(missing_ok=True)
    images = []
    for raw_name, source in uploads:
        name = image_name(raw_name, "upload")
        _claim(staging, name)
        if copy_limited(source, staging / name, budget, name) == 0:
            raise BadUpload(f"{name}: the file is empty")
        images.append(check_image(staging / name, name, max_mpx, staging / THUMBS / name))
    return images


def _unzip_images(raw: Path, shown: str, staging: Path, budget: Budget,
                  max_mpx: int | None) -> list[NewImage]:
    with open_zip(raw, PurePosixPath(shown.replace("\\", "/")).name) as archive:
        entries = zip_entries(archive, budget)
        if not entries:
            raise BadUpload("the zip holds no files")
        images = []
        for info, path in entries:
            name = image_name(path.name, "zip entry")
            _claim(staging, name)
            extract(archive, info, staging / name, budget)
            images.append(check_image(staging / name, name, max_mpx, staging / THUMBS / name))
    return images


def _claim(staging: Path, name: str) -> None:
    if (staging / name).exists():
        raise BadUpload(f"{name} appears twice in the upload")


def file_sha256(path: Path) -> str:
    """The hex SHA-256 of a file's bytes (what tells a batch sent again from a new file)."""
    digest = hashlib.sha256()
    with open(path, "rb") as source:
        while chunk := source.read(CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


def with_hashes(images: list[NewImage], staging: Path) -> list[NewImage]:
    return [dataclasses.replace(image, sha256=file_sha256(staging / image.name)) for image in images]


def discard(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)
