"""Type stubs of the extension module ``surfc._surfc`` (python/src/lib.rs); use the package
``surfc``, which wraps it."""

SURFC_VERSION: str

class Failure(Exception):
    """args: the rendered diagnostics, and their JSON text."""

def check(
    source: str | None = None,
    path: str | None = None,
    defines: list[tuple[str, float]] = ...,
) -> tuple[list[str], list[str], list[tuple[str, float]], str]: ...
def mesh(
    source: str | None = None,
    path: str | None = None,
    defines: list[tuple[str, float]] = ...,
) -> list[tuple[str, bytearray, bytearray, bytearray, str]]: ...
