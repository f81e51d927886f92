"""JSON files read by the Python tools (the report, the format converters, compare_suites.py) with the C++ readers'
nesting limit (io/json_input.h): one reader, so that every tool refuses a too deep file the same way."""
import json
import pathlib

MAX_JSON_DEPTH = 64  # io/json_input.cpp's limit; no input of this tool nests deeper


class JsonTooDeep(ValueError):
    """A JSON file whose arrays and objects nest past MAX_JSON_DEPTH levels. A ValueError, so that every reader
    treats it as it treats a damaged file."""


def read_json(path):
    """path's JSON, or JsonTooDeep naming the file when it nests past MAX_JSON_DEPTH levels: json recurses once a
    level, so a deep enough file would otherwise end in a RecursionError traceback, and readers that walk the value
    recurse too."""
    too_deep = JsonTooDeep(f"{path} nests JSON deeper than {MAX_JSON_DEPTH} levels (arrays and objects inside each "
                           f"other); no input of this tool nests so deep")
    try:
        value = json.loads(pathlib.Path(path).read_text())
    except RecursionError:
        raise too_deep from None
    # Iterative: the check must not recurse on the depth it is there to bound.
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (dict, list)):
            if depth > MAX_JSON_DEPTH:
                raise too_deep
            stack.extend((child, depth + 1) for child in (item.values() if isinstance(item, dict) else item))
    return value
