"""The paper's Fig. 8 (a, b) values, quoted from the paper,
Sec. III-C "Quantitative Results" (8 participants, each mode tested eight times):

    "manual control had the longest completion time ($163.5 \\pm 8.3$~s), while
    autonomous and shared control times were much shorter ($54.1 \\pm 0.1$~s and
    $53.9 \\pm 0.2$~s, respectively). ANOVA confirmed manual control was significantly
    slower than the other modes ($p < 0.01$). [...] shared control achieved a 100\\%
    success rate, outperforming manual ($94\\% \\pm 4\\%$) and autonomous control
    ($59\\% \\pm 5\\%$)"

Success is the proportion of dynamic obstacles avoided. The paper does not say whether
"±" is an SD or an SEM, nor how trials were pooled; we read it as the SD. Its text calls
the completion-time panel (a) and the success panel (b); its Fig. 8 caption has them the
other way round (success (a), time (b)), which our figure follows. The paper has no MPC
mode."""

PAPER_FIG8 = {
    "manual": {"success_mean": 0.94, "success_sd": 0.04, "time_mean_s": 163.5, "time_sd_s": 8.3},
    "autonomous": {"success_mean": 0.59, "success_sd": 0.05, "time_mean_s": 54.1, "time_sd_s": 0.1},
    "shared": {"success_mean": 1.00, "success_sd": 0.0, "time_mean_s": 53.9, "time_sd_s": 0.2},
}
"""Per mode: success rate (fraction) mean and SD, completion time (s) mean and SD, as printed."""
