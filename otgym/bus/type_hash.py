"""ROS 2 type hashes (RIHS01, REP 2011) computed from ``.msg`` definitions.

A ROS 2 type's hash is the SHA-256 of its *type description* serialised as JSON, the
way ``rosidl_generator_type_description`` does it (``calculate_type_hash`` in ros2/rosidl):

- the description is ``{"type_description": T, "referenced_type_descriptions": [R...]}``
  where each entry is ``{"type_name": "pkg/msg/Name", "fields": [...]}`` and the
  referenced types (every nested type, transitively) are sorted by name;
- each field is ``{"name", "type": {"type_id", "capacity", "string_capacity",
  "nested_type_name"}}`` in the order of the ``.msg`` file (its default value is dropped
  before hashing; constants are not fields);
- ``type_id`` follows ``type_description_interfaces/msg/FieldType``: the element type's
  id (int8 2 ... wstring 18, bounded string 21, nested 1) plus 48 for a fixed array,
  96 for a bounded sequence, 144 for an unbounded one; ``capacity`` is the array size
  or bound, ``string_capacity`` the bound of a ``string<=N``;
- JSON with ``", "`` and ``": "`` separators, keys in that order, ASCII only; the hash
  string is ``RIHS01_`` and the 64 lowercase hex digits.

The ``.msg`` text is read in MCAP's ``ros2msg`` form (``otgym.bus.schemas.SCHEMAS``:
the type's own fields, then each dependency after a line of ``=`` and ``MSG:
pkg/Name``). ``builtin_interfaces/Time`` and ``Duration`` need no block. .msg types map
to IDL types as rosidl maps them: ``byte`` is an octet, ``char`` a uint8, ``float32``
and ``float64`` IDL float and double.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import re

_PRIMITIVE_IDS = {
    "int8": 2,
    "uint8": 3,
    "char": 3,
    "int16": 4,
    "uint16": 5,
    "int32": 6,
    "uint32": 7,
    "int64": 8,
    "uint64": 9,
    "float32": 10,
    "float64": 11,
    "bool": 15,
    "byte": 16,
    "string": 17,
    "wstring": 18,
}
NESTED_ID = 1
BOUNDED_STRING_ID, BOUNDED_WSTRING_ID = 21, 22
ARRAY_OFFSET, BOUNDED_SEQUENCE_OFFSET, UNBOUNDED_SEQUENCE_OFFSET = 48, 96, 144
BUILTIN_DEFINITIONS = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "builtin_interfaces/msg/Duration": "int32 sec\nuint32 nanosec\n",
}
"""Types that a ``ros2msg`` schema may use without a ``MSG:`` block (their ROS 2 definitions)."""
_RULE = re.compile(r"^=+\s*$", re.MULTILINE)
_FIELD = re.compile(r"^(?P<type>[A-Za-z][\w/]*(?:<=\d+)?)(?P<array>\[(?:<=)?\d*\])?\s+(?P<name>[a-z]\w*)(?:\s+.*)?$")
RIHS01 = re.compile(r"RIHS01_[0-9a-f]{64}")


class TypeDescriptionError(ValueError):
    """A definition this module cannot describe; ``str()`` says why."""


@dataclasses.dataclass(frozen=True)
class Field:
    name: str
    type_id: int
    capacity: int
    string_capacity: int
    nested_type_name: str

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "type": {
                "type_id": self.type_id,
                "capacity": self.capacity,
                "string_capacity": self.string_capacity,
                "nested_type_name": self.nested_type_name,
            },
        }


def full_name(name: str, package: str) -> str:
    """``pkg/msg/Name`` of a type written ``Name`` (in ``package``), ``pkg/Name`` or ``pkg/msg/Name``."""
    parts = name.split("/")
    if len(parts) == 1:
        return f"{package}/msg/{name}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 3 and parts[1] == "msg":
        return name
    raise TypeDescriptionError(f"not a message type name: {name!r}")


def parse_fields(definition: str, package: str) -> list[Field]:
    """The fields of one ``.msg`` definition (comments, blank lines and constants skipped)."""
    fields = []
    for raw in definition.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        match = _FIELD.fullmatch(line)
        if match is None:
            if re.fullmatch(r"[A-Za-z][\w/]*\s+[A-Z]\w*\s*=.*", line):
                continue  # a constant
            raise TypeDescriptionError(f"cannot read the field line {raw!r}")
        element, array, name = match["type"], match["array"], match["name"]
        string_capacity, nested = 0, ""
        if element.startswith(("string<=", "wstring<=")):
            base, bound = element.split("<=")
            type_id, string_capacity = (BOUNDED_STRING_ID if base == "string" else BOUNDED_WSTRING_ID), int(bound)
        elif element in _PRIMITIVE_IDS:
            type_id = _PRIMITIVE_IDS[element]
        else:
            type_id, nested = NESTED_ID, full_name(element, package)
        capacity = 0
        if array is not None:
            inside = array[1:-1]
            if inside == "":
                type_id += UNBOUNDED_SEQUENCE_OFFSET
            elif inside.startswith("<="):
                type_id, capacity = type_id + BOUNDED_SEQUENCE_OFFSET, int(inside[2:])
            else:
                type_id, capacity = type_id + ARRAY_OFFSET, int(inside)
        fields.append(Field(name, type_id, capacity, string_capacity, nested))
    return fields


def definitions_of(type_name: str, schema_text: str) -> dict[str, list[Field]]:
    """Every type's fields in a ``ros2msg`` schema whose top type is ``type_name`` (``pkg/msg/Name``)."""
    blocks = _RULE.split(schema_text)
    top_package = type_name.split("/")[0]
    definitions = {type_name: parse_fields(blocks[0], top_package)}
    for block in blocks[1:]:
        lines = block.strip("\n").split("\n", 1)
        if not lines[0].startswith("MSG: "):
            raise TypeDescriptionError(f"a dependency block must start with 'MSG: pkg/Name', got {lines[0]!r}")
        name = full_name(lines[0][5:].strip(), top_package)
        definitions[name] = parse_fields(lines[1] if len(lines) > 1 else "", name.split("/")[0])
    for name, text in BUILTIN_DEFINITIONS.items():
        definitions.setdefault(name, parse_fields(text, "builtin_interfaces"))
    return definitions


def type_description(type_name: str, schema_text: str) -> dict:
    """The full type description (the JSON object rosidl hashes, default values dropped)."""
    definitions = definitions_of(type_name, schema_text)
    referenced, queue = set(), [f.nested_type_name for f in definitions[type_name] if f.nested_type_name]
    while queue:
        name = queue.pop()
        if name in referenced:
            continue
        if name not in definitions:
            raise TypeDescriptionError(f"{type_name}: no definition of {name}")
        referenced.add(name)
        queue.extend(f.nested_type_name for f in definitions[name] if f.nested_type_name)

    def describe(name: str) -> dict:
        return {"type_name": name, "fields": [f.as_dict() for f in definitions[name]]}

    return {
        "type_description": describe(type_name),
        "referenced_type_descriptions": [describe(name) for name in sorted(referenced)],
    }


def rihs01(type_name: str, schema_text: str) -> str:
    """``RIHS01_<sha256 hex>`` of ``type_name`` defined by ``schema_text`` (``ros2msg``)."""
    text = json.dumps(type_description(type_name, schema_text), ensure_ascii=True, separators=(", ", ": "))
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()
