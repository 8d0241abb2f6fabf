"""Speed of ``diagnose`` on two rigs, against the cost of one model evaluation measured in the
same run (the baseline):

- the thesis rig: 5 experiments x 8192 samples (simulated, 16-bit ADC, a hidden stiffness change),
  every registered effect, on one and on two worker processes; target 3 s on two workers on a
  quiet machine;
- the two-body machine (projects/rigs/two-body-machine.toml): 3 hits x 8192 samples (simulated, a
  hidden stiffness change), every registered effect, with the candidate fits on one and on two
  worker processes; target 5 s;
- on both: at most CPU_TARGET evaluations' worth of CPU time (the CPU ratio below).

Prints per rig: wall and CPU time (this process and its worker processes), model evaluations, the
time of one evaluation of a structure-changing effect over all experiments (wall and CPU, one BLAS
thread, as diagnose runs them), diagnose / one evaluation in wall and in CPU time (the CPU ratio
holds on a loaded machine, where wall times do not), the verdict and top candidate (the same for
every number of workers), and the speed-up of two worker processes over one. Run with
`.venv/bin/python bench/bench_diagnose.py`.

Figures on a shared two-core machine (CPU seconds of diagnose and its workers; evaluations' worth =
CPU / one evaluation's CPU in the same run, which itself moved from 27 to 40 ms with the load, so
the CPU seconds compare best across runs; wall times at these loads say nothing):

| rig, workers | before: evaluations, CPU, worth (load 4.3-5.1) | after (load 11.0-12.9) | after, again (load 5.4-5.8) |
| --- | --- | --- | --- |
| thesis, 1 | 2130, 50.0 s, 1757 | 1471, 24.2 s, 722 | 1471, 30.0 s, 968 |
| thesis, 2 | 2130, 49.5 s, 1738 | 1471, 23.3 s, 696 | 1471, 23.8 s, 765 |
| two-body, 1 | 1163, 33.7 s, 847 | 1111, 22.6 s, 762 | 1111, 22.7 s, 716 |
| two-body, 2 | 1163, 33.7 s, 847 | 1111, 22.6 s, 761 | 1111, 24.3 s, 767 |

Verdicts, top candidates and errors the same (thesis "partly explained", stiffness 0.7088 -> 0.01256;
two-body "explained", stiffness 0.4916 -> 0.2381). What changed: the band-limited force is kept
between simulations (a tenth of an evaluation), a problem keeps its last predictions, a pair's search
starts from the better of its starts (the thesis rig's mass_properties+nonlinear_stiffness pair:
700 -> 300 evaluations; measured with the pairs on the workers, which the partner search that came
after runs in the main process). Both targets are still missed: on the thesis
rig the pairs' joint fits are half the CPU (the pair with cubic springs alone a third), on the
two-body rig the screening of every candidate and the two full fits share it evenly.

The next round: a pair's joint fit also starts from each member's fit with the other nominal and
stops where its linearisation cannot come within 4x of the simplest significant single's sum of
squares (joint.accepted would reject it), every fit stops where its linearisation promises less
than one noise energy, and a model's modal decomposition is kept for all experiments. Before and
after on the same machine, one run after the other:

| rig, workers | before: evaluations, CPU, worth (load 5.4-7.8) | after (load 5.2-5.7) |
| --- | --- | --- |
| thesis, 1 | 2612, 69.2 s, 2037 (192.2 s wall) | 1683, 27.9 s, 850 (33.8 s wall) |
| thesis, 2 | 2612, 58.9 s, 1735 (84.6 s wall) | 1683, 22.9 s, 698 (35.1 s wall) |
| two-body, 1 | 1111, 26.2 s, 785 (35.1 s wall) | 1023, 21.4 s, 670 (41.8 s wall) |
| two-body, 2 | 1111, 28.6 s, 857 (52.7 s wall) | 1023, 20.8 s, 652 (26.8 s wall) |

One evaluation 32-34 ms CPU in both runs. Verdicts, top candidates and errors the same; on the
thesis rig every candidate's significance and order the same, the singles' errors to four digits;
the pair mass_properties+nonlinear_stiffness (not accepted before either) now stops at 45
evaluations instead of 689. Where the CPU goes now (one worker, `bench/profile_diagnose_stages.py`
splits it by stage and effect; thesis): screening every candidate
~30 %, the partner search ~20 %, the four full fits ~20 %, the pairs' joint fits ~15 %; two-body:
screening ~60 %, the two full fits ~35 %. Both targets are still missed by 2.6-3.4x. Tried and
left out: screening every candidate on the shortest head only and the best eight on the longer
ones (thesis 1683 -> 1411 evaluations): a plate's bending mode that shows only on the longer heads
was screened at no gain (0.709 instead of 0.672), so the shortest head cannot choose which to
refine.

On a quiet machine (load 0.9) after that round: thesis 1683 evaluations, 22.2 s on one worker and
15.5 s on two, 553 / 471 evaluations' worth of CPU (one evaluation 31 ms wall, 41 ms CPU); two-body
1023 evaluations, 18.4 s / 10.2 s, 470 / 473 worth. Targets (3 s / 5 s, 250 worth) missed.

The next round: a Jacobian of three or more structure-changing columns linearises the structure's
response in its modes' poles and residues (fitting.Problem._linearised: the modes' signals and
their pole derivatives once per experiment, the channel chain once over them, each column a
product) instead of simulating each column. Before and after on one worker, one run after the
other in the same checkout (the old path by setting fitting.LINEARISED_FROM beyond any Jacobian):

| rig, one worker | before: evaluations, CPU (load 1.1-3.7) | after |
| --- | --- | --- |
| thesis | 1683, 24.4 s CPU (872 worth, one evaluation 28 ms) | 1703, 19.8 s CPU (818 worth, 24 ms) |
| two-body | 1023, 23.6 s CPU (792 worth, 30 ms) | 1023, 18.8 s CPU (553 worth, 34 ms) |

The CPU seconds fell by a fifth on both rigs; the worth column moves with the baseline evaluation's
own CPU time, which varied by a fifth between runs at that load. Verdicts, candidate order,
significance, likelihood ratios and errors the same (errors to 4-5 digits); the thesis rig's search
took 20 more evaluations. Jacobians alone (two-body fit windows, alternating, best of three):
stiffness 223 -> 163 ms, mass_properties 389 -> 256 ms, damping 219 -> 168 ms; thesis
mass_properties 102 -> 66 ms, its stiffness (7 columns) 66 -> 60 ms. After, at load 8.3 (other
work on the machine; these wall times and CPU ratios say little): thesis 1703 evaluations, 29.0 s
CPU on one worker and 28.7 s on two, 989 / 979 worth (one evaluation 29 ms CPU, 136 ms wall),
156.6 / 153.1 s wall. Targets (3 s / 5 s, 250 worth) still missed by about 3x: at the fit
windows' lengths a column's simulation is about half its cost, the rest (building the model, its
eigen-decomposition, the sensors' rows, the combination of the basis signals) stays per column;
screening (every candidate, mostly on short heads) is still about half of diagnose's CPU.

This bench, main's code (before) and this one (after) one right after the other, load 2.0-2.7
(other work on the machine):

| rig, workers | before: evaluations, CPU, worth, wall | after |
| --- | --- | --- |
| thesis, 1 | 1683, 23.4 s, 639, 22.9 s | 1703, 20.6 s, 723, 21.0 s |
| thesis, 2 | 1683, 27.4 s, 748, 22.6 s | 1703, 23.6 s, 825, 23.4 s |
| two-body, 1 | 1023, 22.4 s, 505, 22.3 s | 1023, 19.2 s, 536, 19.4 s |
| two-body, 2 | 1023, 20.6 s, 465, 20.1 s | 1023, 19.2 s, 538, 16.0 s |

On a quiet machine (load 0.9) after that round, with the early/late check of the best candidate:
thesis 1703 evaluations, 23.2 s CPU / 22.7 s wall on one worker, 19.7 s CPU / 16.0 s wall on two
(698 / 591 evaluations' worth; one evaluation 22 ms wall, 33 ms CPU); two-body 1023 evaluations,
18.5 s CPU on one and on two workers, 18.1 s / 9.6 s wall (399 / 400 worth; one evaluation 46 ms
CPU). Verdicts and errors as above. Targets (3 s / 5 s, 250 worth) missed by 2.4-5x.

CPU seconds 7-14 % lower after; the worth column rose because the baseline evaluation measured
36.6 / 44.3 ms CPU before (more than its 25.9 / 32.7 ms wall: some other thread of the process
ran meanwhile; cause not found) and 28.6 / 35.7 ms after: at this load the baseline, not diagnose,
decides that ratio. Verdicts, top candidates and errors the same in every run.

The next round: a candidate that changes the sensors alone (gain, tilt, position, cables)
simulates nothing and filters nothing per evaluation: the chain's filtering of the kept
coordinates, once per distinct channel chain, is combined by its sensor rows
(prediction.predict_sharing), the rows before their gain kept per structure (Model._unit_row);
screening skips the sweep of a candidate with nothing to sweep and takes no gain below rounding
(fitting.ROUNDING). Main's code (before) and this one (after), one right after the other on a
loaded machine (load 8.8-9.4 before, 9.3-4.8 after; wall times say nothing):

| rig, workers | before: evaluations, CPU, worth | after |
| --- | --- | --- |
| thesis, 1 | 1703, 33.3 s, 1036 | 1703, 27.8 s, 822 |
| thesis, 2 | 1703, 26.6 s, 828 | 1703, 24.9 s, 735 |
| two-body, 1 | 1023, 25.2 s, 687 | 1013, 21.2 s, 525 |
| two-body, 2 | 1023, 26.3 s, 718 | 1013, 24.4 s, 602 |

Again, one right after the other at load 3.9-4.4 (CPU, worth, wall):

| rig, workers | before | after |
| --- | --- | --- |
| thesis, 1 | 26.6 s, 780, 31.5 s | 26.2 s, 719, 26.7 s |
| thesis, 2 | 26.3 s, 771, 26.4 s | 26.1 s, 715, 26.2 s |
| two-body, 1 | 24.2 s, 598, 24.8 s | 23.0 s, 536, 23.5 s |
| two-body, 2 | 24.6 s, 609, 24.8 s | 25.1 s, 583, 25.3 s |

So the gain is small: 0-17 % of the CPU seconds, within the runs' own spread at these loads
(one evaluation 32-43 ms CPU; two workers no faster than one, the second core being busy).
Screening alone (two-body, one process, alternating, load 6): 9.7 / 11.7 s CPU before, 9.2 / 9.5
s after. Verdicts, significance and errors the same (errors and likelihood ratios within 2e-7
relative); the order changed only among candidates with no gain at all (screened error equal to
the baseline's to the last digit), which rounding noise used to order. Targets (250 worth, 3 s /
5 s) still missed by 2-3x. Where the CPU goes (cProfile, two-body, one worker): screening ~12 s
of ~20 s, of it ~7 s the structure-changing candidates (each start's damped step simulates new
structures on three record heads; nonlinear_stiffness's eight cubic columns each a nonlinear
simulation, for no gain on this rig), the two full fits ~7 s (per iteration a Jacobian of ~212,000
rows and scipy's SVD of it, ~0.1 s). What a sound method would still need: screening by one step
from one linearised Jacobian per candidate instead of a damped step on each head (it changes the
screened errors of the candidates not fitted, so the nulls' and faults' calibration must be
measured again), and the full fits' trust-region steps on the Jacobian's QR factor instead of
all its rows.

On a quiet machine (load 0.2-1.3), the code before this round and after it with the held-out
test besides, single runs of this script: thesis one worker 27.0 -> 20.3 s wall, 27.4 -> 20.9 s
CPU (701 -> 513 worth), two workers 18.5 -> 20.9 s wall, 22.8 -> 25.8 s CPU (583 -> 633);
two-body (1023 -> 1013 evaluations) one worker 18.7 -> 21.7 s wall, 19.1 -> 22.3 s CPU
(477 -> 451), two workers 12.9 -> 12.3 s wall, 24.4 -> 23.0 s CPU (609 -> 465). Single runs
scatter more than the change moves them.

The next round tried the screening by one damped step on the fit windows: a candidate with one
start (nothing to sweep, no frequency or period: stiffness, damping, mass properties, gains,
positions) screened by one damped Gauss-Newton step from its Jacobian at nominal on the whole fit
windows (linearised where the structure changes), judged by real evaluations, instead of a damped
step on each of the three record heads; a candidate going on to a full fit carried through the
heads' continuation first, so its fit started and ended where it did. On the benches it gave the
same verdicts, messages and fitted candidates with 8-13 % fewer evaluations (thesis 1703 -> 1488,
two-body 1013 -> 933) and CPU within the loaded runs' spread (load 6-10: one worker two-body
22.8 -> 20.9 s, thesis 24.1 -> 25.2 s; by stage on the two-body rig screening 17.7 -> 11.6 s CPU,
the fitted candidates' continuation about 3 s more in the fit stage): at these fit windows
(2,500-4,800 samples with the 512 before the hit) a head is a fifth to a quarter of a window, so
leaving out the heads saves the two heads' Jacobians, about 40 % of the window's, and the fitted
candidates pay them again. It was taken out again: the calibration's faults set named 17 of 20
(main 20/20: thesis softer-mount s200 and s218, two-body softer-mount s202 missed). On s218 the
one step on the windows screened stiffness at 0.380 where the heads reach 0.067, below
mass_properties, and the fit stage skipped it as unable to compete: a mount change that moves
modes by 5-15 % (there 97 -> 90 Hz and 217 -> 188 Hz) makes the whole window's error as
non-convex as a frequency's, so the cheap step misranks the effects the heads were for. Candidates with starts kept the heads throughout (one step on the
windows from their best start on the shortest head had also ranked the thesis plate's bending mode
below a mounted mode). Also tried and left out: fits from that step's point without the
continuation (two-body 950 evaluations instead of 923: the fits' extra iterations).

Kept: a parameter's starts may be a ladder (Parameter.ladder, nonlinear_stiffness's hardening
decades), which the sweep climbs until a rung raises the error, instead of simulating every
decade of every spring group (each a nonlinear simulation over the whole windows on the two-body
rig, whose slow suspension leaves no head for the sweep). Measured with the quick screening above
(the same code but for the ladder, one after the other): two-body 923 -> 883 evaluations, thesis
1426 -> 1398; verdicts, messages and every fitted candidate (the thesis rig's nonlinear_stiffness
fit included) the same. On this code against main's, one worker, one right after the other (load
3.4-4.5): two-body 1013 -> 973 evaluations, 21.0 -> 22.0 s CPU (613 -> 597 worth); thesis 1703 ->
1675, 27.8 -> 25.8 s CPU (666 -> 723 worth: the baseline evaluation's CPU moved 42 -> 36 ms);
candidate tables the same to the digits printed (every candidate's significance, errors,
screened errors, likelihood ratios), verdicts and messages too. A few per cent of the evaluations,
no CPU gain beyond the runs' spread. This script, main's code (load 4.0-4.4) then this (load
3.0-4.4, falling to 0.2 at its end):

| rig, workers | before: evaluations, CPU, worth, wall | after |
| --- | --- | --- |
| thesis, 1 | 1703, 22.0 s, 857, 48.5 s | 1675, 24.7 s, 770, 35.6 s |
| thesis, 2 | 1703, 27.9 s, 1087, 52.6 s | 1675, 22.3 s, 695, 21.5 s |
| two-body, 1 | 1013, 21.5 s, 507, 41.9 s | 973, 19.4 s, 495, 20.7 s |
| two-body, 2 | 1013, 21.5 s, 508, 23.7 s | 973, 19.7 s, 504, 15.6 s |

(one evaluation 25.7 / 42.4 ms CPU before, 32.1 / 39.2 ms after); verdicts and top candidates
the same. Calibration on this code (niced, one set at a time but nulls
beside faults, --workers 1): faults 20/20 named and explained; nulls no significant candidate in
40/40 ("nothing to explain" 38, "unexplained" 2: seeds 123 and 136, as before); outside 0/8
"explained"; the pairs' slow tests (two_faults, corrected, rattle) 7 passed.

Where the CPU is (main's code, bench/profile_diagnose_stages.py, one worker, load 2-3; one
evaluation 41 ms / 28 ms CPU): two-body 26.0 s = 640 worth, screening 436 of it (the candidates
with starts or grids, missing_mode, plate_flexibility(_free), channel_swap, channel_delay,
nonlinear_stiffness, about three quarters; nonlinear_stiffness alone 172), the two full fits 166
(their Jacobians, ~0.25 s each, and scipy's SVDs, ~0.11 s each); thesis 22.2 s = 791 worth, the
pairs 381 (the partner search 170), screening 206, the four full fits 135. Targets (250 worth,
3 s / 5 s) missed by 2.5-3x. What a sound method would still need: a cheaper continuation, not
fewer heads (the heads are what keeps a stiffness's error convex); starts judged from one
linearised Jacobian instead of a Jacobian and a step per start on the shortest head; the fits'
trust-region steps from one QR factor; the cubic springs' columns at nominal as the linear
structure's response to the cubic force of its nominal motion (first order, no nonlinear
simulation per column).

The next round judges two kinds of screening start without simulating each: nonlinear_stiffness's
columns from zero hardening are the linear structure's response to the cubic force of the nominal
motion (prediction.cubic_change_predictions; one recursion per mode), and a structure's
resonance-frequency grid (plate_flexibility's starts) is ranked by projecting the fit windows'
residual on the force convolved with a damped sine and cosine at each frequency, only the best two
(fitting.GRID_KEPT) getting a Jacobian and a damped step. Evaluations: thesis 1675 -> 1455,
two-body 973 -> 879. Screening alone (profile_diagnose_stages, two-body, one worker): 484 -> 346
worth (nonlinear_stiffness 197 -> 38) though the load rose from 3.6 to 8-11 (the untouched full fits
read 185 -> 222 worth meanwhile); thesis plate_flexibility's screening 1.70 -> 0.51 s CPU, the free
shape's 1.95 -> 0.51 s, both to the same screened error and values. The bench, main's code then
this, one right after the other at load 8.7-11 (CPU seconds, worth; wall times there say nothing):

| rig, workers | before: evaluations, CPU, worth | after |
| --- | --- | --- |
| thesis, 1 | 1675, 32.4 s, 913 | 1455, 23.8 s, 938 |
| thesis, 2 | 1675, 26.5 s, 747 | 1455, 27.0 s, 1065 |
| two-body, 1 | 973, 21.9 s, 621 | 879, 21.4 s, 610 |
| two-body, 2 | 973, 19.8 s, 562 | 879, 21.2 s, 605 |

(one evaluation 35.5 / 35.3 ms CPU before, 25.3 / 35.0 ms after: the worth column follows it.) At
this load the CPU gain is within the runs' spread. Verdicts, top candidates and errors the same;
thesis candidate table the same to the digits printed (every significance, error, screened error,
likelihood ratio); two-body the same but for the order among candidates with no gain (the free
plate shape's gain below the fifth digit came from a start now ranked out). The demo's loop the
same (0.469 -> stiffness -> plate_flexibility at 639.9 Hz -> "nothing to explain"). Calibration
on this code (niced, --workers 1, nulls beside faults, at load 6-11): faults n 20: 20/20 named
and explained (s215 also calls missing_mode significant, as main's code does); nulls n 20: 20/20
"nothing to explain", no significant candidate in 20/20; outside n 8: 0/8 "explained". Targets
(250 worth, 3 s / 5 s) still missed by 2-3x: the two-body rig's two full fits alone are about 190
worth, and the rest of screening is spread over a dozen candidates at 10-45 worth each (the
structure-changing ones' Jacobians at one natural step are simulated column by column: the
linearisation refuses poles that move that far).

The next round changed the iterative fits alone (fitting._trf): scipy's trust-region reflective
steps, step for step with its own functions, on the n x n square root of J^T J instead of an SVD
of every Jacobian row per iteration (0.1 s on the two-body rig's ~212,000 rows, 25x the product
J^T J; without updates the iterates are scipy's), and Broyden's rank-one update of the Jacobian
after an accepted step instead of differencing it (at most 3 in a row, while the steps gain
within half of what they predict; a stop on an updated Jacobian's promise and the result's
Jacobian use a differenced one). A rejected step already reused the Jacobian in scipy. The fit
stage (bench/profile_diagnose_stages.py, main then this, load 4-6): two-body 5.5 -> 3.3 s CPU
(mass_properties 6 Jacobians either way, stiffness 10 -> 5), thesis 7.5 -> 5.7 s (thesis
stiffness crawls through 17 Jacobians either way; the pairs, nonlinear_stiffness and sensor_orientation save 1-3
each). This script, main then this, one after the other at load 6-11 (wall times say nothing):

| rig, workers | before: evaluations, CPU, worth | after |
| --- | --- | --- |
| thesis, 1 | 1675, 28.1 s, 724 | 1643, 25.0 s, 826 |
| thesis, 2 | 1675, 25.8 s, 666 | 1643, 26.2 s, 864 |
| two-body, 1 | 973, 20.1 s, 605 | 922, 16.8 s, 413 |
| two-body, 2 | 973, 25.0 s, 753 | 922, 17.5 s, 430 |

(one evaluation 38.8 / 33.2 ms CPU before, 30.3 / 40.7 ms after: the worth column follows the
baseline). Two more sittings, main then this, CPU seconds on one / two workers: at load 3.7
thesis 22.0 / 20.4 -> 22.3 / 23.8 s, two-body 17.2 / 17.5 -> 18.3 / 17.9 s; at load 1.3-2.1
thesis 19.6 / 25.0 -> 25.2 / 20.5 s, two-body 21.8 / 20.7 -> 15.7 / 18.6 s (wall 16-25 s, two-body
on two workers 9.5-11 s). The whole diagnose's CPU scatters by a quarter between runs, more than
the fits change it; the fit stage alone, measured again at load 2: two-body 5.1 -> 3.1 s, thesis
6.3 -> 5.0 s (diagnose 17.1 -> 15.0 s and 21.2 -> 20.2 s). Verdicts, significance and the candidate tables' order the same; fitted errors within
6e-5 relative but for the pair mass_properties+nonlinear_stiffness, stopped where it cannot come
near stiffness (1.6e-3); the two-body stiffness's 11 scales moved up to 8 sds along the direction
the data cannot see (reported as one redundant group; the printed mount stiffnesses the same).
The fits were a quarter of the CPU: targets still missed by 2-3x; the rest is screening and the
partner search. Calibration on this code (niced, --workers 1, faults and nulls side by side):
faults 20/20 named and explained; nulls 20/20 "nothing to explain", no significant candidate;
the pairs' slow tests (two_faults, corrected) 5 passed; `odsuite demo`'s loop 0.469 -> stiffness
-> plate_flexibility -> "nothing to explain".

The screening and fits rounds merged with the statistics' changes, on a quiet machine (load
0.4-0.9; the same code but for the fits' confirmation of an updated Jacobian's stop in the second):

| rig, workers | evaluations | CPU, worth, wall | again |
| --- | --- | --- | --- |
| thesis, 1 | 1431 | 19.2 s, 479, 18.7 s | 21.9 s, 553, 21.6 s |
| thesis, 2 | 1431 | 23.8 s, 594, 18.9 s | 18.8 s, 474, 14.9 s |
| two-body, 1 | 828 | 14.7 s, 353, 14.1 s | 14.6 s, 338, 14.1 s |
| two-body, 2 | 828 | 15.7 s, 377, 8.8 s | 16.4 s, 382, 8.7 s |

Against the round before (load 1-2: thesis 1675 evaluations, 22.0 s CPU; two-body 973, 20.3 s):
thesis 0-13 % less CPU, two-body 28 %. Verdicts and errors the same. Calibration on that code:
nulls n 40 no significant candidate in 40/40, faults n 20 20/20 named and explained, outside n 8
0/8 "explained". Targets (250 worth, 3 s / 5 s) still missed by 1.4-2.2x in CPU worth and 1.7-5x
in wall time.

The next round balanced the worker processes. Each task's CPU by process
(bench/profile_diagnose_workers.py) showed the thesis rig's partner search and pairs' joint fits
running in the main process while both workers idled (10 of 22 s CPU), which bounded two workers'
speed-up at 1.27x (critical path, the main process's CPU plus the busiest worker's per stage: 17.3
of 22.0 s). Both now run on the workers, a fit's kept predictions travel back with it, and a
worker that has finished takes the next full fit. Same sitting, load 16: critical path 14.0 of
23.8 s CPU, at most 1.70x; two-body (no pairs) 10.8 of 17.8 s before, 12.9 of 21.7 after (1.66x,
1.68x): what remains is the main process's own work (baseline, ordering, verdict: about 2 s) and
the fits' uneven ends (mass properties 3 s beside stiffness 2 s). This script after it (load 14-15, wall times say
nothing): thesis 1431 evaluations, 22.2 / 22.0 s CPU on one / two workers (793 / 785 worth, one
evaluation 28 ms CPU); two-body 828, 16.8 / 15.6 s (501 / 465 worth, 33.5 ms). Candidate tables
and evaluations on one worker bit for bit as before on both rigs; on two within round-off (the
last digits of a few sensor-only candidates, as before between one and two workers).

The next round: screening's structure-changing Jacobian columns on the heads are derivatives,
linearised over DIFF_STEP natural steps (over a natural step the poles moved as far as their gaps:
the linearisation refused every one and each column was simulated), and the damped step takes its
Gram matrix and gradient once (a sensor candidate's whole-window Jacobian was copied and multiplied
twice). Screening Jacobians (two-body) mass_properties 0.96 -> 0.46 s CPU, damping 0.55 -> 0.26,
stiffness 0.40 -> 0.26; sensor_position's whole-window step 0.19 -> 0.04 s. Screening alone (every
candidate, one process, main and this alternating twice at load 10-17): two-body 10.5-10.6 ->
7.0-7.1 s CPU, thesis 5.5-6.2 -> 4.8-4.9 s. This script, main then this at load 11-16 (wall times
say nothing): thesis 1431 -> 1369 evaluations, 24.6 -> 21.1 s CPU on one worker, 23.3 -> 18.9 s on
two; two-body 828 -> 835, 17.2 -> 13.9 s and 17.0 -> 13.3 s. Verdicts, top candidates, the
significant candidates and their order the same; screened errors moved (thesis stiffness 0.0505 ->
0.0650, its fit then 19 evaluations instead of 33; damping 0.5648 -> 0.5661), fitted errors within
3e-5 relative, validated ones within 2e-3 (two-body mass_properties 0.4891 -> 0.4899). Demo loop
unchanged; calibration on this code (niced, --workers 1, n 12 each): faults 12/12 named and
explained, nulls 12/12 "nothing to explain" with no significant candidate. Targets still missed by
1.5-2x in CPU worth.

The next round made one evaluation cheaper to the bit (odsuite/domain/recursions.py: a simulation's
mode recursions and a channel group's scaling, offset and causal sections in one compiled call each,
lfilter's and sosfilt's operations in their order; a cubic-coefficient fit's linear set-up kept;
every prediction and Jacobian of both benches' diagnoses traced equal to main's, so no
recalibration; measured on the code before the two rounds above were merged). One evaluation, alternating, best of 7 x 10 (load 8-15): thesis 20.5-25.8 ->
11.5-14.4 ms CPU, two-body 30.2-34.9 -> 18.7-20.4 ms; on the record heads (5 x 614 samples) 6.0 ->
3.5-5.0 ms. Diagnose, thesis, one worker, alternating main / this (load 12-15): 20.1, 20.5, 19.4 s
-> 13.7, 15.3, 13.7 s CPU. This script, main then this at load 15-17, then this then main at load 15-18
(CPU s, worth; evaluations and verdicts the same): thesis one worker 22.3 (975) -> 13.8 (1068),
19.5 (616) -> 20.5 (869); two workers 22.2 (972) -> 14.3 (1099), 20.6 (652) -> 18.6 (788);
two-body one worker 16.9 (536) -> 12.5 (576), 14.8 (474) -> 13.2 (617); two workers 17.3 (549)
-> 14.0 (644), 14.7 (470) -> 14.2 (665). Diagnose's CPU falls by about as much as the baseline's
(both run the same prediction code, long records and short heads alike), so the worth column does
not fall. Merged with the two rounds above, this script, main then this at load 4.5-5 (CPU s,
worth; wall): thesis 1369 evaluations, one worker 21.1 (652; 31.5 s) -> 12.3 (850; 17.5 s), two
16.0 (496; 24.3 s) -> 12.7 (873; 19.2 s); two-body 835, one worker 10.7 (366) -> 9.9 (411), two
11.7 (401) -> 10.8 (450); one evaluation 32.3 -> 14.5 and 29.1 -> 24.0 ms CPU; every prediction
and Jacobian of both diagnoses again equal to main's to the bit. Targets still missed by 1.6-3.5x
in worth and 4-6x in wall time.

The next round: the partner search (diagnose._partner, each candidate screened again on top of
the best single's fit) judges a candidate without discrete choices, projected parameters, starts
or a frequency or period by one damped Gauss-Newton step from its Jacobian at that fit on the
whole fit windows (diagnose._screen_on_top) instead of a step on each head: the residual left
there is small, and the heads are for the non-convex parameters, which keep fitting.screen
(sensor_dynamics' corner frequencies, screened by the one step too, gained nothing where the
heads take 0.9 % off). Thesis rig (the two-body rig's diagnose tries no pairs: unchanged): 1431
-> 1317 evaluations, the partner search 419 -> 305 (mass_properties 40 -> 12, damping 31 -> 9,
impact_location 51 -> 17); bench/profile_diagnose_stages.py thesis, main then this one right
after the other at load 13-16: diagnose 25.1 -> 21.9 s CPU, the pairs 10.9 -> 8.6 s, the
partner search 4.6 -> 3.1 s. The candidate table the same to every digit (every error,
screened error, likelihood ratio, the four pairs' fits and reasons); the pairs calibration's
gain + moved centre of mass (s300) names mass_properties+sensor_gain as before (x3 0.7108,
parameters within 1e-6 relative), 1149 -> 1067 evaluations. The pairs are still a third of the
thesis rig's CPU: the partner candidates with starts or grids (~1.6 s), the joint fits (~2 s:
stiffness+nonlinear_stiffness 39 evaluations, rejected for a likelihood ratio of -25) and their
validation (~1 s). Next: stop a joint fit from its linearisation where it cannot beat the member
joint.accepted tests it against (the BIC and likelihood-ratio rules, not only 4x the simplest
single's sum of squares).
Merged with main's worker-run partner search (one worker, load 3.9, main then this one right
after the other): thesis 1369 -> 1263 evaluations, the partner search 350 -> 278 evaluations and
3.5 -> 2.8 s CPU, diagnose 24.1 -> 23.4 s CPU; the candidate table the same to every digit.
"""

from __future__ import annotations

import resource
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "core"))

from hidden_effects import CASES, make_project  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from odsuite.diagnosis.diagnose import diagnose  # noqa: E402
from odsuite.analysis.modelrev import revision_model  # noqa: E402
from odsuite.contracts.plugins import registries  # noqa: E402
from odsuite.analysis.prediction import predict, prepare  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402

TWO_BODY = ROOT / "projects" / "rigs" / "two-body-machine.toml"
#: diagnose's CPU time (all processes) in evaluations' worth, at most
CPU_TARGET = 250
#: the two-body rig's hits: down on the machine's top, along -x on its side, along +y on the base (mm)
TWO_BODY_HITS = (((100, 50, 250), (0, 0, -1)), ((150, -50, 200), (-1, 0, 0)), ((100, -200, 25), (0, 1, 0)))


def two_body_project(path: Path) -> Path:
    from odsuite.processing.acquisition import acquire
    from odsuite.contracts.daq import AcquisitionSettings
    from odsuite.store.project import create_project

    p = create_project(path, rig=str(TWO_BODY))
    try:
        for i, (point, direction) in enumerate(TWO_BODY_HITS):
            acquire(p, registries().daq_backends.get("sim"), f"hit{i + 1}",
                    AcquisitionSettings(sampling_rate=10240.0, n_samples=8192, pretrigger=512),
                    point=tuple(1e-3 * v for v in point), direction=direction, seed=20 + i,
                    effects=[("stiffness", {"scale_z": 0.8})])
    finally:
        p.close()
    return path


def cpu_seconds() -> float:
    """CPU time of this process and of its finished worker processes."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def one_evaluation(project, exps) -> tuple[float, float]:
    """Wall and CPU seconds for one evaluation of a structure-changing effect (a new structure,
    its eigen-decomposition, simulated for every experiment) on one BLAS thread: the baseline."""
    base = revision_model(project).shared
    stiff = registries().effects.get("stiffness")
    reps = 10
    with threadpool_limits(1):
        c0, t0 = cpu_seconds(), time.perf_counter()
        for k in range(reps):
            model = stiff.apply(base, {"scale_z": 1.0 + 0.01 * (k + 1)})
            for e in exps:
                predict(model, e)
        return (time.perf_counter() - t0) / reps, (cpu_seconds() - c0) / reps


def run(path: Path, label: str, target: float, workers: tuple[int, ...]) -> None:
    with open_project(path) as p:
        exps = prepare(p)
        one, one_cpu = one_evaluation(p, exps)
        walls = {}
        for w in workers:
            c0, t0 = cpu_seconds(), time.perf_counter()
            d = diagnose(p, prepared=[replace(e, _cache=None) for e in exps], workers=w)
            walls[w] = (time.perf_counter() - t0, cpu_seconds() - c0, d)
    n_eff = len(registries().effects.names())
    print(f"{label}: {len(exps)} experiments x {exps[0].n_samples} samples, {n_eff} effects registered")
    print(f"  one evaluation (baseline) {1e3 * one:.1f} ms wall, {1e3 * one_cpu:.1f} ms CPU")
    for w, (wall, cpu, d) in walls.items():
        print(f"  workers {w}: diagnose {wall:.1f} s wall ({cpu:.1f} s CPU), {d.evaluations} model evaluations, "
              f"{wall / one:.0f} evaluations' time wall, {cpu / one_cpu:.0f} in CPU "
              f"(target {target:g} s: {'met' if wall <= target else 'missed'}; "
              f"{CPU_TARGET} in CPU: {'met' if cpu / one_cpu <= CPU_TARGET else 'missed'})")
    if len(walls) > 1:
        print(f"  workers {workers[-1]} vs {workers[0]}: {walls[workers[0]][0] / walls[workers[-1]][0]:.2f}x wall")
    for w, (_, _, d) in walls.items():
        top = d.candidates[0]
        print(f"  workers {w}: verdict {d.verdict!r}: top {top.effect} (significant {top.significant}), error "
              f"{d.baseline_error:.4g} -> {top.error_after:.4g}, noise floor {d.noise_floor_error:.4g}")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        thesis = make_project(Path(tmp) / "thesis.odsp", [("stiffness", CASES["stiffness"])])
        run(thesis, "thesis rig", 3.0, (1, 2))
        machine = two_body_project(Path(tmp) / "two-body.odsp")
        run(machine, "two-body machine", 5.0, (1, 2))


if __name__ == "__main__":
    main()
