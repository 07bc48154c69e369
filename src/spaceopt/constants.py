"""Physical constants, in SI units, in one place only.

Sources: the dissertation (Yun 2023) §1.1 and §4 intro as extracted in spec/02-multirev.md §1;
g0 is the standard gravity that reproduces every checked number of the dissertation.
"""
G0 = 9.80665                       # m/s^2, standard gravity (c = Isp * g0)
MU_EARTH_THESIS = 3.98600436e14    # m^3/s^2, dissertation §1.1 (central term, §4.1)
R_EARTH_MEAN = 6371.0e3            # m, mean Earth radius from which altitudes are measured
MU_SUN = 1.32712440018e20          # m^3/s^2, dissertation §4 intro
MU_MOON = 4.902799e12              # m^3/s^2, dissertation §4 intro
DAY = 86400.0                      # s
