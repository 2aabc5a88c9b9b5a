"""What a user asks to simulate: the scene schema, loading and validation, expressions, and the
built-in scenes (``builtin/``)."""

from rodfem.scene.loading import (
    BUILTIN,
    EXTRA,
    METHODS,
    SCHEMA,
    Scene,
    SceneError,
    load,
    read,
    split_key,
    validate,
    with_values,
)

__all__ = ["BUILTIN", "EXTRA", "METHODS", "SCHEMA", "Scene", "SceneError", "load", "read",
           "split_key", "validate", "with_values"]
