"""Join the cv runs (NEAT, polish, speed polish) and the sp2 runs (the speed polish's restart,
run from a copy of the cv walker) into runs/rs, laid out as the benchmark's
--speed-polish-restarts 1 lays a seed out."""
import json, shutil
from pathlib import Path

rs = Path("runs/rs")
for s in range(1, 6):
    cv, sp, dst = Path(f"runs/cv/seed{s}"), Path(f"runs/sp2/seed{s}"), rs / f"seed{s}"
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(cv, dst, ignore=shutil.ignore_patterns("kept.json", "checkpoint.json"))
    if not (sp / "result.json").exists() or "speed_polish" not in json.loads((sp / "result.json").read_text()):
        continue
    first, restarted = json.loads((cv / "result.json").read_text()), json.loads((sp / "result.json").read_text())
    shutil.copytree(sp / "speed_polish", dst / "speed_polish_restart1",
                    ignore=shutil.ignore_patterns("kept.json", "checkpoint.json"))
    to_rs = lambda path: (path.replace(f"runs/sp2/seed{s}/polish/", f"runs/rs/seed{s}/speed_polish/")
                          .replace(f"runs/sp2/seed{s}/speed_polish/", f"runs/rs/seed{s}/speed_polish_restart1/")
                          .replace(f"runs/cv/seed{s}/", f"runs/rs/seed{s}/"))
    restart = restarted.pop("speed_polish")
    restart.update(controller=to_rs(restart["controller"]), polished=to_rs(restart["polished"]))
    merged = {**restarted, "walker": to_rs(restarted["walker"]), "speed_polish": first["speed_polish"],
              "speed_polish_restarts": [restart]}
    (dst / "result.json").write_text(json.dumps(merged, indent=1))
    print(s, merged["walker"], merged["rate"])
