"""Write the JSON Schemas of the TOML files to docs/schemas/ (from their pydantic models)."""

from __future__ import annotations

from pathlib import Path

from auvlink.cli.schemas import write_schemas

if __name__ == "__main__":
    for path in write_schemas(Path(__file__).resolve().parents[1] / "docs" / "schemas"):
        print(path)
