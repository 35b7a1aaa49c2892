"""Every public function, class and method of the package has a docstring with an example
(`>>>`), which the test command runs as a doctest (pytest --doctest-modules on the package)."""

import inspect

import femvi
import femvi.dask


def public_items():
    for name in femvi.__all__:
        obj = getattr(femvi, name)
        if name in ("InputError",):  # defined in the Rust extension (documented in _core.pyi)
            continue
        yield f"femvi.{name}", obj
        if inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if attr.startswith("_"):
                    continue
                f = member.fget if isinstance(member, property) else member
                if callable(f):
                    yield f"femvi.{name}.{attr}", f
    yield "femvi.dask.ensemble", femvi.dask.ensemble


def test_every_public_item_has_an_example():
    missing = [name for name, obj in public_items() if ">>>" not in (inspect.getdoc(obj) or "")]
    assert not missing, missing
