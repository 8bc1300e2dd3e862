"""The sensor's response in a calibration record: the time constants its lag is undone with.

    from shared.response import check_response
    resp = check_response({"model": "first-order", "tau_s": [0.0318] * 3})   # validated copy

A first-order sensor of bandwidth f_c lags the field by tau = 1 / (2 pi f_c); the true
reading is r = y + tau dy/dt (docs/cli.md, "Slow sensors"). The record's "response":
{"model": "first-order", "tau_s": [3] s per axis, "tau_sigma_s": [3] s (optional, the
estimate's uncertainty), "source": "given" | "estimated" (optional)}. Keys besides these
may carry JSON scalars, as meta's may. A record without one has no lag to undo.
"""

MODELS = ("first-order",)
SOURCES = ("given", "estimated")
# 1 s is a 0.16 Hz bandwidth: slower than any magnetometer that is turned by hand
TAU_LIMIT_S = 1.0


def _taus(value, what):
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError("%s must be a list of 3 numbers (s)" % what)
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError("%s[%d] is not a number" % (what, i))
        v = float(v)
        if not 0.0 <= v <= TAU_LIMIT_S:
            raise ValueError("%s[%d] %r outside 0..%r s" % (what, i, v, TAU_LIMIT_S))
        out.append(v)
    return out


def check_response(resp):
    """The response record validated, as a new dict; ValueError naming the first problem."""
    if not isinstance(resp, dict):
        raise ValueError("response must be a JSON object")
    if resp.get("model") not in MODELS:
        raise ValueError("response.model must be one of %s" % ", ".join(MODELS))
    if "tau_s" not in resp:
        raise ValueError("response has no 'tau_s'")
    out = {}
    for k in resp:
        v = resp[k]
        if k in ("model", "tau_s", "tau_sigma_s", "source"):
            continue
        if not (v is None or isinstance(v, (bool, int, float)) or (isinstance(v, str) and len(v) <= 256)):
            raise ValueError("response.%s: a number, short text, true/false or null expected" % str(k)[:40])
        out[k] = v
    out["model"] = resp["model"]
    out["tau_s"] = _taus(resp["tau_s"], "response.tau_s")
    if "tau_sigma_s" in resp:
        out["tau_sigma_s"] = _taus(resp["tau_sigma_s"], "response.tau_sigma_s")
    if "source" in resp:
        if resp["source"] not in SOURCES:
            raise ValueError("response.source must be one of %s" % ", ".join(SOURCES))
        out["source"] = resp["source"]
    return out
