"""The study file read safely: a size limit, YAML aliases counted before they expand, duplicate
keys refused, and every problem one line that names the file and where in it."""

from __future__ import annotations

import re
from collections.abc import Hashable
from pathlib import Path
from typing import Any

import yaml

from demcal.errors import ConfigError

#: Largest study file demcal reads (bytes); a study is a few hundred lines.
MAX_STUDY_FILE_BYTES = 1_000_000


#: Most values a study file may hold once its YAML aliases are expanded.
MAX_STUDY_VALUES = 100_000


class StrictLoader(yaml.SafeLoader):
    """YAML's safe loader, strict where a study file needs it.

    A key given twice in one mapping is refused (YAML keeps the last), and
    plain scalars such as 5e6 are numbers as in YAML 1.2 (PyYAML follows
    YAML 1.1, where an exponent needs a dot and a sign); quoted text stays text.
    """

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Hashable, Any]:
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise ConfigError(
                    f"duplicate key {key!r} (line {key_node.start_mark.line + 1}): "
                    f"YAML would silently keep only the last one; remove one"
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def expanded_size(node: yaml.Node, limit: int) -> int:
    """Values in a composed YAML document with every alias expanded, counted up to ``limit``.

    Aliases share their node, so composing costs nothing; a few hundred bytes
    of nested aliases (a "billion laughs" file) would expand into billions of
    values when the study is read, and a node that contains itself forever.
    """
    sizes: dict[int, int] = {}

    def size(item: yaml.Node, inside: frozenset[int]) -> int:
        if id(item) in sizes:
            return sizes[id(item)]
        if id(item) in inside:
            raise ConfigError("a YAML alias refers to the node that contains it")
        children = (
            [part for pair in item.value for part in pair]
            if isinstance(item, yaml.MappingNode)
            else item.value
            if isinstance(item, yaml.SequenceNode)
            else []
        )
        total = 1
        for child in children:
            total += size(child, inside | {id(item)})
            if total > limit:
                break
        sizes[id(item)] = total
        return total

    return size(node, frozenset())


def _yaml_problem(error: yaml.YAMLError) -> str:
    """PyYAML's several-line message as one clause: where, then what."""
    mark = getattr(error, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
    problem = getattr(error, "problem", None) or str(error)
    return f"{where}: {' '.join(problem.split())}"


def read_study_yaml(path: str | Path) -> dict[str, Any]:
    """The mapping of a YAML study file, read strictly; every problem is a
    ConfigError naming the file."""
    path = Path(path)
    try:
        with path.open("rb") as stream:
            raw = stream.read(MAX_STUDY_FILE_BYTES + 1)
        if len(raw) > MAX_STUDY_FILE_BYTES:
            raise ConfigError(
                f"larger than {MAX_STUDY_FILE_BYTES // 1000} kB; a study file is a "
                f"few hundred lines of YAML"
            )
        loader = StrictLoader(raw.decode("utf-8"))
        try:
            document = loader.get_single_node()
            if (
                document is not None
                and expanded_size(document, MAX_STUDY_VALUES) > MAX_STUDY_VALUES
            ):
                raise ConfigError(
                    f"its YAML aliases expand to more than {MAX_STUDY_VALUES} values "
                    f"(nested aliases, a 'billion laughs' file?); write the study "
                    f"out without them"
                )
            config = loader.construct_document(document) if document is not None else None
        finally:
            loader.dispose()
    except FileNotFoundError:
        raise ConfigError(f"configuration file not found: {path}") from None
    except IsADirectoryError:
        raise ConfigError(f"{path} is a directory; give the study's YAML file") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except (
        OSError
    ) as exc:  # permission denied, an I/O error: the Snakefile too prints it in one line
        raise ConfigError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML{_yaml_problem(exc)}") from None
    except RecursionError:
        raise ConfigError(f"{path}: nested too deeply to be a study file") from None
    if not isinstance(config, dict):
        raise ConfigError(
            f"{path}: a study file is a YAML mapping (study:, engine:, parameters:, ...)"
        )
    if "__use_yte__" in config:  # refused before Snakemake would render it (and run its code)
        raise ConfigError(
            f"{path}: __use_yte__: a study file is data, not a YTE template "
            f"(whose Python expressions Snakemake would run); write the values out"
        )
    return config
