"""Print the training variant to report on: the one whose validation evaluation (``/root/val/val_<name>``) reached
>= 99 % at 3 m with <= 0.5 % falls on every terrain, then the smallest rugged pitch + roll variance; if none did, the
best mean success. Usage: python scripts/device/choose_variant.py NAME ..."""

import json
import sys

rows = {}
for n in sys.argv[1:]:
    try:
        with open(f"/root/val/val_{n}/results.json") as f:
            r = json.load(f)["results"]
    except OSError:
        continue
    ok = all(r[t]["cpg_rl"]["success_3m"] >= 0.99 and r[t]["cpg_rl"]["fall_rate"] <= 0.005 for t in r)
    succ = sum(r[t]["cpg_rl"]["success_3m"] for t in r) / len(r)
    var = r["rugged"]["cpg_rl"]["pitch_var_deg2"] + r["rugged"]["cpg_rl"]["roll_var_deg2"]
    rows[n] = (ok, succ if not ok else 1.0, -var)
if not rows:
    sys.exit("choose_variant.py: no validation results under /root/val")
print(max(rows, key=rows.get))
