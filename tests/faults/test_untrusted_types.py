"""``echo``/``hz`` import only ROS message modules, whatever type name another participant advertises."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from msd_bench.commands.topics import TopicError, import_type

CRAFTED = [
    "os/path/join",                # a module path, not a message
    "subprocess/msg/Popen",        # a real module with a msg-shaped name
    "antigravity/msg/Geohash",     # importing the package alone would run its code
    "std_msgs/srv/Empty",          # a service, not a message
    "std_msgs/msg/String/extra",
    "../std_msgs/msg/String",
    "std_msgs.msg/msg/String",
    "std_msgs/msg/_String",        # a private name of the module
    "std_msgs/msg/NoSuchType",
    "std_msgs/msg/string",
    "",
]


@pytest.mark.parametrize("ros_type", CRAFTED)
def test_a_crafted_type_is_one_unsupported_type_line(ros_type: str) -> None:
    with pytest.raises(TopicError, match=r"^unsupported type ") as err:
        import_type(ros_type)
    assert "\n" not in str(err.value)
    assert "antigravity" not in sys.modules


def test_a_package_that_is_not_a_message_package_is_never_imported(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A package on sys.path shaped like one (``evil/msg/__init__.py``) without rosidl type support."""
    marker = tmp_path / "imported"
    pkg = tmp_path / "evilpkg"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "__init__.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    (pkg / "msg" / "__init__.py").write_text("class Boom:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(TopicError, match=r"^unsupported type 'evilpkg/msg/Boom': evilpkg is not an"):
        import_type("evilpkg/msg/Boom")
    assert not marker.exists() and "evilpkg" not in sys.modules


@pytest.mark.parametrize("ros_type", ["std_msgs/msg/Float64", "sensor_msgs/msg/JointState",
                                      "rosgraph_msgs/msg/Clock", "diagnostic_msgs/msg/DiagnosticArray"])
def test_real_message_types_still_resolve(ros_type: str) -> None:
    cls = import_type(ros_type)
    assert cls.__name__ == ros_type.rsplit("/", 1)[1]
    assert hasattr(cls, "get_fields_and_field_types")
