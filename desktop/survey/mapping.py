"""From a survey capture to a processed grid and its anomalies (what `fluxcal map` and the bench run).

    result = make_map("survey.npz", cal=None, steps=("despike", "drift", "destripe"))
    result.grid, result.anomalies, result.report, result.stripes_nT
"""

import numpy as np

from desktop.formats import FormatError

from desktop.sim.field import DECLINATION_DEG, INCLINATION_DEG, earth_vector
from desktop.survey.anomalies import find_anomalies
from desktop.survey.gridding import interpolate
from desktop.survey.processing import STEPS, process, stripes_nT
from desktop.survey.traverses import read_survey


class MapResult:
    def __init__(self, **kw):
        self.__dict__.update(kw)


def make_map(path, cal=None, steps=STEPS, interpolate_across=True, sample_m=0.125, threshold_nT=None,
             sensor_height_m=0.3):
    """Read, process, grid and search a survey; `stripes_nT` is taken before destriping (after drift)."""
    lines, grid = read_survey(path, cal, sample_m)
    if not lines:      # a survey stopped before its first line was marked
        raise FormatError("%s: no traverse in it: no line was marked start and end (nothing to map)" % path)
    stripes = []
    report = process(lines, steps, before_destripe=lambda ls: stripes.append(stripes_nT(ls)))
    mg = interpolate(lines, grid, interpolate_across)
    samples = np.concatenate([np.c_[ln.north_m, np.full(len(ln.nT), ln.east_m), ln.nT] for ln in lines])
    fdir = earth_vector(1.0, INCLINATION_DEG, DECLINATION_DEG)
    anomalies, threshold = find_anomalies(mg, samples, fdir, sensor_height_m, threshold_nT)
    report.append("interpolate: %s onto %.3f m (north) x %.3f m (east) cells" % (
        "linear across the lines" if interpolate_across else "off, one column per traverse",
        mg.cell_m()[0], mg.cell_m()[1]))
    return MapResult(lines=lines, survey_grid=grid, grid=mg, anomalies=anomalies, threshold_nT=threshold,
                     report=report, stripes_nT=stripes[0])

