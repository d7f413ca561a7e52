"""The energy ledger: every term of the audit named once — its accumulator, its metric, its side.

The compiled loop adds the dissipations and the work of the loads into an ``energy`` array as it
steps (indices ``E_*``); the state terms (kinetic, elastic) are read off the state at the end.
:func:`audit` turns both into the metrics ``energy_*_j`` (J per track) and the balance's mismatch
``energy_error`` = |in − out| / (energy delivered to the soil).
"""

from __future__ import annotations

import numpy as np

# accumulators of the compiled loop (J per unit thickness or per radian): plastic, hourglass and
# bulk-viscosity dissipation, work of the push, of gravity on the body and on the soil, the
# changes of elastic and kinetic energy that the remap makes, the work lost to slip at a
# limited-adhesion contact, the elastic energy gap cells let go, and the work of redrawing a turning
# body (the soil energy its moves change: dsmv.cel.turn)
(E_PLASTIC, E_HOURGLASS, E_BULK, E_PUSH, E_BODY_GRAV, E_SOIL_GRAV, E_REMAP_ELASTIC, E_REMAP_KINETIC,
 E_FRICTION, E_GAP_RELEASE, E_REDRAW) = range(11)
N_ENERGY = 11

#: energy put in: metric name → accumulator (None: the touchdown's kinetic energy, given)
INPUTS = {
    "energy_in_kinetic_j": None,
    "energy_in_gravity_body_j": E_BODY_GRAV,
    "energy_in_gravity_soil_j": E_SOIL_GRAV,
    "energy_in_push_j": E_PUSH,
    "energy_in_redraw_j": E_REDRAW,
}

def audit(energy: np.ndarray, *, kinetic_in: float, kinetic_soil: float, kinetic_body: float,
          elastic_change: float, touchdown_loss: float, scale: float) -> dict[str, float]:
    """Every energy term on its own (J per track, the model's values times ``scale``), and the
    relative mismatch of the balance.

    In: the body's kinetic energy at touchdown, the work of gravity on body and soil, the work
    of the push, the work of redrawing a turning body. Out: kinetic (soil, body) and elastic energy now, plastic, hourglass and
    bulk-viscosity dissipation, slip at a limited-adhesion contact, the elastic energy a gap cell
    lets go, the touchdown impact, and what the remap changed (a remap that smooths stress or
    velocity loses energy; soil entering at the base brings its elastic energy).
    """
    terms = {name: (kinetic_in if index is None else energy[index]) for name, index in INPUTS.items()}
    terms |= {
        "energy_kinetic_soil_j": kinetic_soil,
        "energy_kinetic_body_j": kinetic_body,
        "energy_elastic_change_j": elastic_change,
        "energy_plastic_j": energy[E_PLASTIC],
        "energy_hourglass_j": energy[E_HOURGLASS],
        "energy_bulk_viscosity_j": energy[E_BULK],
        "energy_touchdown_loss_j": touchdown_loss,
        "energy_remap_loss_j": -(energy[E_REMAP_ELASTIC] + energy[E_REMAP_KINETIC]),
        "energy_contact_slip_j": energy[E_FRICTION],
        "energy_gap_release_j": energy[E_GAP_RELEASE],
    }
    inputs = sum(terms[k] for k in INPUTS)
    outputs = sum(v for k, v in terms.items() if k not in INPUTS)
    delivered = sum(abs(terms[k]) for k in INPUTS)
    out = {k: float(v) * scale for k, v in terms.items()}
    out["energy_error"] = abs(inputs - outputs) / max(delivered, 1e-300)
    return out


def delivered(energy: np.ndarray, kinetic_in: float) -> float:
    """The energy put in so far, every input counted positive (J in the model's units)."""
    return kinetic_in + sum(abs(energy[k]) for k in INPUTS.values() if k is not None)
