"""Read-only dict-style access for the typed facts of a report (`report.tactile["plate_mm"]`), so
notebooks and scripts written against the earlier dicts keep working. A foundation module."""

from __future__ import annotations

import dataclasses


class Facts:
    """Mixin for a dataclass: `as_dict()` (JSON-ready), `facts[key]` and `facts.get(key)` read it."""

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)  # type: ignore[call-overload]

    def __getitem__(self, key: str):
        return self.as_dict()[key]

    def get(self, key: str, default=None):
        return self.as_dict().get(key, default)

    def __contains__(self, key: str) -> bool:
        return key in self.as_dict()
