"""The corrected ICL crop of CI's test (views 0, 3, 4 at 320, seed 0): Regions with and
without prior_region_crease, maps and fused cloud scored through the Python package."""
import mvscope

GT = "/tmp/scenes/extra/rgbd/icl-reg"
scene = mvscope.Scene.open(GT, max_image_size=320, views=[0, 3, 4])
for method, crease in [(m, c) for m, c in (("acmm", False), ("regions", False), ("regions", True)) if m in __import__("sys").argv[1:] or not __import__("sys").argv[1:]]:
    params = {"prior_region_crease": crease} if method == "regions" else {}
    s = mvscope.Session(scene, method=method, seed=0, params=params)
    s.run()
    d = mvscope.evaluate(s, gt=GT)
    c = mvscope.evaluate_cloud(s, gt=GT, thresholds=(0.02, 0.05))
    weak = d.overall.low_texture[0.02]
    print(f"{method:8} crease={crease!s:5}: within 2% {100 * d.within(0.02):.1f}, weak {100 * weak:.1f}, "
          f"within 5% {100 * d.within(0.05):.1f}, F1 2 / 5 cm {100 * c.f1(0.02):.1f} / {100 * c.f1(0.05):.1f}, "
          f"per view within 2% {[round(100 * v.within(0.02), 1) for v in d.views]}")
