#!/usr/bin/env python3
"""Convert NIST's PTFE.data.csv (T. A. Germer, Applied Optics 2017) to sbrdf's long CSV layout.

Usage: nist_ptfe_to_csv.py PTFE.data.csv > nist_ptfe_fr11.csv

The source columns are lambda (um), thetai (deg, negative: the source stood on the -x side),
phi, thetar, phir and the Mueller matrix elements; only f_r11 (the unpolarised BRDF, 1/sr) is
kept. Azimuths are rotated by 180 degrees so that the light is at phi_i = 0 and the specular
peak at phi_o = 180, sbrdf's convention.
"""
import csv
import sys

rows = csv.DictReader(open(sys.argv[1]))
out = sys.stdout
out.write("theta_i,phi_i,theta_o,phi_o,wavelength_nm,value\n")
for r in rows:
    ti = abs(float(r["thetai"]))
    po = (float(r["phir"]) + 180.0) % 360.0
    out.write(f"{ti:g},0,{r['thetar']},{po:.10g},{float(r['lambda']) * 1000:g},{r['f_r11']}\n")
