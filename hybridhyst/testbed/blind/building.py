"""How a blind case is built: ``BlindCase`` (what a case function returns), the per-process cache of the
noise-free simulations, the nominal switch (``nominal=True`` or effect names switched off), the noise added to the
output of a copy, and the small record helpers the case modules share. ``_make_case_fn`` turns a case's spec
function into its public case function."""

from dataclasses import dataclass

import numpy as np

from .noise import _noise_text, make_noise


@dataclass
class BlindCase:
    name: str
    effects: tuple[str, ...]
    description: str
    base_law: str
    kind: str
    units: dict
    noise_sd: float
    records: list[dict]
    held_out: list[str]
    validation: list[str]
    noise_model: tuple = ("white",)  # ("white",), ("ar1", phi) or ("lowpass", order, cutoff fraction)


_CACHE: dict[tuple[str, frozenset], dict] = {}


def _off_set(effects, nominal):
    if nominal is True:
        return frozenset(effects)
    if nominal is False or nominal is None:
        return frozenset()
    off = frozenset([nominal]) if isinstance(nominal, str) else frozenset(nominal)
    unknown = off - frozenset(effects)
    if unknown:
        raise ValueError(f"effects {sorted(unknown)} are not part of this case {effects}")
    return off


def _build(name, spec_fn, effects, noise, nominal):
    off = _off_set(effects, nominal)
    key = (name, off)
    spec = _CACHE.get(key)
    if spec is None:
        spec = spec_fn(off)
        _CACHE[key] = spec
    rng = np.random.default_rng(spec["seed"])
    records = []
    for rname, t, x, y, cond in spec["records"]:
        e = make_noise(rng, len(t), spec["noise_sd"], spec["noise_model"])
        yy = y + e if noise else y.copy()
        records.append(
            {"name": rname, "t": t.copy(), "x": x.copy(), "y": yy, "conditions": {k: float(v) for k, v in cond.items()}}
        )
    desc = spec["description"] + " " + _noise_text(spec["noise_model"], spec["noise_sd"], spec["units"]["y"])
    if off:
        desc = f"[NOMINAL VARIANT for diagnostics: effect(s) {', '.join(sorted(off))} switched off] " + desc
    return BlindCase(
        name=name,
        effects=tuple(spec["effects"]),
        description=desc,
        base_law=spec["base_law"],
        kind=spec["kind"],
        units=dict(spec["units"]),
        noise_sd=float(spec["noise_sd"]),
        records=records,
        held_out=list(spec["held_out"]),
        validation=list(spec["validation"]),
        noise_model=tuple(spec["noise_model"]),
    )


def _rec(name, t, x, y, cond):
    return (name, np.asarray(t, float), np.asarray(x, float), np.asarray(y, float), cond)


def _af(A, f):
    return {"amplitude": float(A), "frequency_hz": float(f)}


def _sine_name(prefix, A, f):
    return f"{prefix}{A:g}_f{f:g}"


def _make_case_fn(name, spec_fn, effects):
    def fn(noise: bool = True, nominal=False) -> BlindCase:
        return _build(name, spec_fn, effects, noise, nominal)

    fn.__name__ = name
    fn.__qualname__ = name
    fn.__doc__ = (
        f"Blind case {name!r} (effects: {', '.join(effects) or 'none'}).  noise=False: noise-free "
        "truth.  nominal=True: the same experiment with every effect switched off; "
        "nominal=<effect name or iterable of names>: only those switched off (diagnostics only)."
    )
    fn.effects = tuple(effects)
    return fn
