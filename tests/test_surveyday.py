"""The survey-day benchmark, reduced (python -m desktop.bench.surveyday runs the full day):
three Mag649s (seeds 1-3; seed 3 has the largest gain drift, -42 ppm/C) with its temperature model and both ADS1292 references drifting, calibrated
at 10 C and 25 C (30 s each), a 180 s warm-up rotation from 10 to 25 C, spins at 10 and
25 C. Issue 11's target at 25 C: compensated within 1.5x of the floor (the exact
calibration there, on the same codes), while the uncompensated 10 C calibration grows."""

from desktop.bench.surveyday import TARGET, run, tables


def test_compensated_spins_stay_within_the_target_of_the_floor():
    res = run(sensors=3, cal_s=30.0, warmup_s=180.0, temps=(10.0, 25.0))
    for r in res:
        spins = r["spins"]
        floor = spins[25.0]["floor"][0]
        for name in ("two calibrations", "warm-up"):
            assert spins[25.0][name][0] <= TARGET * floor, tables(res, (10.0, 25.0))
        unc = spins[25.0]["uncompensated"][0]
        assert unc > 3 * floor and unc > 3 * spins[10.0]["uncompensated"][0], tables(res, (10.0, 25.0))
        assert r["warmup"]["gains"] == "per_axis"
