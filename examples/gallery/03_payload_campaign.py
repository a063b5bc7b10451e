"""A campaign under payloads and temperatures
===========================================

A KUKA KR 210 carries 0, 75 and 150 kg during the day and warms from 20 to 35 deg C. The joints
yield under the load and the links expand with the heat: a purely geometric calibration averages
these effects away and leaves an error that grows with how far the load and the temperature are
from that average (here, on a stiff arm, about as large as the tracker's noise). Each row of
the data records its payload and temperature; calibrating with the ``payload`` and ``thermal``
terms models both. The arm is then judged at a payload and temperature
it was never calibrated at (110 kg, 28 deg C). Simulated, fixed seeds, known truth.
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import robocal as rc

# %% The campaign: 300 poses in three payload blocks, the arm warming within each block
nominal = rc.Robot.from_catalog("kuka_kr210_r2700")
sim = rc.simulate_tracker(nominal, 300, payloads=[0, 75, 150], temperatures=(20, 35),
                          seed=3)
print(sim.summary())

# %% The held-out set: the same true arm at 110 kg and 28 deg C
held = rc.simulate_tracker(sim.truth, 100, as_is=True, payloads=[110],
                           temperatures=(28, 28), seed=3)
print(f"held-out poses at 110 kg, 28 deg C; noise floor {held.noise_floor_mm:.4f} mm")

# %% Two calibrations of the same data: geometry only, and geometry + payload + thermal
models = {"geometric": "none", "payload, thermal": "payload,thermal"}
results = {name: rc.calibrate(nominal, sim.data, nongeometric=terms, validation=held.data,
                              progress=False)
           for name, terms in models.items()}
for name, res in results.items():
    ratio = res.validation["rms"] / held.noise_floor_mm
    print(f"{name:<17} held-out RMS {res.validation['rms']:.4f} mm "
          f"= {ratio:.2f} x the noise floor")

# %% What the model found against the truth: two joints' compliance, the expansion
found = {p["name"]: p for p in results["payload, thermal"].nongeometric["parameters"]}
for name, unit in (("payload2", "urad/(kg m)"), ("payload3", "urad/(kg m)"),
                   ("thermal", "1e-6/K")):
    scale = 1e6  # rad/(kg m) and 1/K in the model: micro-units printed
    est, sigma = found[name]["estimate"] * scale, found[name]["sigma"] * scale
    true = sim.truth.get(name) * scale
    print(f"{name:<9} found {est:.4f} +- {sigma:.4f} {unit}, true {true:.4f} "
          f"({abs(est - true) / sigma:.1f} sigma off)")

# %% Figure: the held-out error of each pose with the two models
fig, ax = plt.subplots(figsize=(5, 3), layout="constrained")
for name, res in results.items():
    errors = np.sort(res.judged[0].errors[1]) * 1e3
    ax.plot(errors, np.linspace(0, 1, len(errors)), label=name)
ax.axvline(held.noise_floor_mm, color="grey", ls=":", label="noise floor")
ax.set(xlabel="held-out position error at 110 kg, 28 deg C, mm", ylabel="fraction of poses",
       xscale="log", title="KR 210: payload and temperature in the model")
ax.legend()
fig.savefig("03_payload_campaign.png", dpi=120)
