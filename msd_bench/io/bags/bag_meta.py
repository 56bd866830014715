"""A bag's ``metadata.yaml`` and stored parameters, read with bounds and checked field by field.

Why: rosbags parses ``metadata.yaml`` whole and indexes into it, so a file of
gigabytes, YAML nested deep enough for ``RecursionError``, or a field of the
wrong type (a list where a mapping belongs) used to surface as a library
traceback. Here the file is read under :data:`MAX_METADATA_BYTES`, parsed by
PyYAML's safe loader, and every field a reader uses is type-checked before
rosbags or ``bag check`` sees it; every fault is one :class:`BagError` line
naming the bag and the field. The experiment parameters in ``custom_data``
are JSON, read by :func:`msd_bench.io.storage.safe_read.loads_bounded`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import Any

import yaml

from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_writer import PARAMS_KEY
from msd_bench.io.storage.safe_read import loads_bounded

MAX_METADATA_BYTES = 4 << 20
"""Largest ``metadata.yaml`` read (4 MiB): ours are a few KiB, a long rig recording's tens of KiB."""

_Loader: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@dataclass(frozen=True)
class TopicCount:
    """One ``topics_with_message_count`` entry."""

    name: str
    """Topic name."""
    ros_type: str
    """Message type."""
    count: int
    """Messages the metadata claims on the topic."""


@dataclass(frozen=True)
class BagMetadata:
    """The fields of ``metadata.yaml`` the readers use, each of the right type."""

    storage: str
    """``storage_identifier``: ``mcap`` or ``sqlite3``."""
    files: tuple[str, ...]
    """``relative_file_paths``, as plain file names."""
    topics: tuple[TopicCount, ...]
    """Per-topic message counts."""
    message_count: int
    """Total message count."""
    start_ns: int
    """``starting_time``, ns since the epoch."""
    duration_ns: int
    """``duration``, ns."""
    compression_mode: str
    """``compression_mode`` (empty or ``none`` when uncompressed)."""
    custom: dict[str, str]
    """``custom_data``."""


def read_metadata(bag: Path) -> BagMetadata:
    """``bag/metadata.yaml``, bounded and checked; one BagError line naming the bag and field otherwise."""
    doc = _load(bag, bag / "metadata.yaml")
    info = _field(bag, doc, "rosbag2_bagfile_information", Mapping)
    files = tuple(_name(bag, f) for f in _field(bag, info, "relative_file_paths", list))
    entries = _field(bag, info, "topics_with_message_count", list)
    topics = tuple(_topic(bag, i, t) for i, t in enumerate(entries))
    custom = info.get("custom_data") or {}
    if not isinstance(custom, Mapping) or not all(isinstance(k, str) and isinstance(v, str)
                                                  for k, v in custom.items()):
        raise BagError(f"bag {bag}: metadata.yaml custom_data must map strings to strings")
    mode = info.get("compression_mode") or ""
    if not isinstance(mode, str):
        raise BagError(f"bag {bag}: metadata.yaml compression_mode must be a string")
    return BagMetadata(
        storage=_field(bag, info, "storage_identifier", str),
        files=files,
        topics=topics,
        message_count=_count(bag, info, "message_count"),
        start_ns=_nanoseconds(bag, info, "starting_time", "nanoseconds_since_epoch"),
        duration_ns=_nanoseconds(bag, info, "duration", "nanoseconds"),
        compression_mode=mode,
        custom=dict(custom),
    )


def _load(bag: Path, meta: Path) -> Any:
    try:
        with meta.open("rb") as fh:
            data = fh.read(MAX_METADATA_BYTES + 1)
    except OSError as exc:
        raise BagError(f"bag {bag}: cannot read metadata.yaml ({exc.strerror or exc})") from None
    if len(data) > MAX_METADATA_BYTES:
        raise BagError(f"bag {bag}: metadata.yaml is over the {MAX_METADATA_BYTES}-byte limit")
    try:
        return yaml.load(data, Loader=_Loader)
    except RecursionError:
        raise BagError(f"bag {bag}: metadata.yaml is nested too deeply") from None
    except yaml.YAMLError as exc:
        text = " ".join(str(exc).split())[:200]
        raise BagError(f"bag {bag}: metadata.yaml is not valid YAML ({text})") from None


def _field(bag: Path, doc: Any, key: str, kind: type) -> Any:
    if not isinstance(doc, Mapping):
        raise BagError(f"bag {bag}: metadata.yaml must be a mapping holding {key}")
    value = doc.get(key)
    if not isinstance(value, kind):
        raise BagError(f"bag {bag}: metadata.yaml {key} must be {_KIND_NAMES[kind]}, "
                       f"got {type(value).__name__}")
    return value


_KIND_NAMES: dict[type, str] = {Mapping: "a mapping", list: "a list", str: "a string", int: "an integer"}


def _count(bag: Path, doc: Any, key: str) -> int:
    value = _field(bag, doc, key, int)
    if isinstance(value, bool) or value < 0:
        raise BagError(f"bag {bag}: metadata.yaml {key} must be a count >= 0, got {value!r}")
    return int(value)


def _nanoseconds(bag: Path, doc: Mapping[str, Any], key: str, inner: str) -> int:
    value = _field(bag, _field(bag, doc, key, Mapping), inner, int)
    if isinstance(value, bool):
        raise BagError(f"bag {bag}: metadata.yaml {key}.{inner} must be an integer")
    return int(value)


def _name(bag: Path, value: object) -> str:
    if not isinstance(value, str) or not value:
        raise BagError(f"bag {bag}: metadata.yaml relative_file_paths must list file names")
    return PurePath(value).name


def _topic(bag: Path, i: int, entry: object) -> TopicCount:
    where = f"topics_with_message_count[{i}]"
    if not isinstance(entry, Mapping):
        raise BagError(f"bag {bag}: metadata.yaml {where} must be a mapping")
    meta = entry.get("topic_metadata")
    if not isinstance(meta, Mapping) or not isinstance(meta.get("name"), str) \
            or not isinstance(meta.get("type"), str):
        raise BagError(f"bag {bag}: metadata.yaml {where}.topic_metadata needs a string name and type")
    count = entry.get("message_count")
    if not isinstance(count, int) or isinstance(count, bool) or count < 0:
        raise BagError(f"bag {bag}: metadata.yaml {where}.message_count must be a count >= 0")
    return TopicCount(meta["name"], meta["type"], int(count))


def params_from_custom(bag: Path, custom: object) -> dict[str, Any]:
    """The experiment parameters in ``custom_data`` (empty when none): a bounded JSON object.

    ``custom`` is what the reader found as ``custom_data`` (None for a bare
    ``.mcap``); anything but a mapping of strings, or parameters that are not
    a JSON object within :mod:`.safe_read`'s bounds, is a BagError naming the bag.
    """
    if custom is None:
        return {}
    if not isinstance(custom, Mapping):
        raise BagError(f"bag {bag}: custom_data must map strings to strings")
    text = custom.get(PARAMS_KEY)
    if text is None:
        return {}
    if not isinstance(text, str):
        raise BagError(f"bag {bag}: custom_data {PARAMS_KEY} must be a string of JSON")
    value = loads_bounded(text, f"bag {bag}: custom_data {PARAMS_KEY}", BagError)
    if not isinstance(value, dict):
        raise BagError(f"bag {bag}: custom_data {PARAMS_KEY} must be a JSON object, "
                       f"got {type(value).__name__}")
    return value


def shown(text: str) -> str:
    """A name read from a bag, fit for a one-line message: as is when printable, else its repr."""
    return text[:200] if text.isprintable() else repr(text)[:200]
