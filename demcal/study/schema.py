"""The study file's JSON schema (workflow/schemas/config.schema.yaml): the one place for the
study's defaults (`default`), and a violation of it told in one sentence that names the
field, the value and what is allowed (`validate_schema`)."""

from __future__ import annotations

import functools
from typing import Any

import jsonschema
import yaml

from demcal.errors import ConfigError, unknown_field
from demcal.resources import SCHEMA_PATH


def _field_path(error: jsonschema.ValidationError) -> str:
    parts = []
    for item in error.absolute_path:
        parts.append(f"[{item}]" if isinstance(item, int) else f".{item}")
    return "".join(parts).lstrip(".") or "(top level)"


def _schema_message(error: jsonschema.ValidationError, schema: dict[str, Any]) -> str:
    """One clear sentence for a schema violation: field, value, what is allowed."""
    where, kind = _field_path(error), error.validator
    # jsonschema's stubs add an "unset" marker to these; a reported error has them all set
    value: Any = error.instance
    expected: Any = error.validator_value
    subschema: Any = error.schema
    if kind == "additionalProperties":
        allowed = sorted(subschema.get("properties", {}))
        extra = sorted(set(value) - set(allowed)) if isinstance(value, dict) else []
        name = f"{where}.{extra[0]}" if where != "(top level)" and extra else (extra or [where])[0]
        return unknown_field(name, allowed)
    if kind == "required":
        return f"{where}: missing required field {error.message.split(' ')[0]}"
    if kind in ("enum", "const"):
        choices = expected if kind == "enum" else [expected]
        return f"{where}: {value!r} is not one of {', '.join(map(str, choices))}"
    if kind in ("oneOf", "anyOf"):
        forms = [
            "one of " + ", ".join(map(str, form["enum"]))
            if "enum" in form
            else {"array": "a list"}.get(form.get("type"), str(form.get("type")))
            for form in expected
        ]
        return f"{where}: {value!r} is not allowed; give {' or '.join(forms)}"
    if kind == "pattern":
        return (
            f"{where}: {value!r} is not a valid name (letters, digits, '_' and '-', "
            f"starting with a letter)"
        )
    if kind in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
        words = {"minimum": ">=", "maximum": "<=", "exclusiveMinimum": ">", "exclusiveMaximum": "<"}
        return f"{where}: {value!r} must be {words[kind]} {expected}"
    if kind in ("minItems", "minProperties"):
        given = len(value)
        return f"{where}: {given or 'none'} given; give at least {expected}" + (
            " (their standard deviation is the spread)" if where.endswith("repeats") else ""
        )
    if kind == "type":
        wanted = expected if isinstance(expected, list) else [expected]
        if isinstance(value, str) and {"number", "integer"} & set(wanted):
            return f"{where}: {value!r} is text, not a number ({' or '.join(wanted)}); " + (
                "write it without quotes"
                if _reads_as_number(value)
                else "a percentage is not read: give the number in the field's unit"
                if value.strip().endswith("%")
                else "give a plain number (units go in the unit field)"
            )
        return f"{where}: {value!r} is not of type {expected}"
    return f"{where}: {error.message}"


def _reads_as_number(text: str) -> bool:
    """Whether ``text`` is a number written in quotes."""
    try:
        float(text)
    except ValueError:
        return False
    return True


@functools.cache
def load_schema() -> dict[str, Any]:
    schema: dict[str, Any] = yaml.safe_load(
        SCHEMA_PATH.read_text()
    )  # a mapping: the schema's top level
    return schema


def default(*path: str) -> Any:
    """The schema's ``default`` of a study field, e.g. ``default("calibration", "retries")``.

    The schema is the one place for the defaults of the study file.
    """
    node = load_schema()
    for name in path:
        node = node.get("items", node)["properties"][name]  # arrays: the items' fields
    return node["default"]


def validate_schema(config: dict[str, Any]) -> None:
    schema = load_schema()
    validator = jsonschema.Draft202012Validator(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(config))
    if error is not None:
        raise ConfigError(_schema_message(error, schema))
