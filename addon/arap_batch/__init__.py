# SPDX-License-Identifier: GPL-3.0-or-later
"""The arap-batch launcher's library (plain Python 3, standard library only; never imported by Blender).

reports   the JSON report: build, write, summary and exit code, merging shards and reruns
runfolder a sharded run's folder (file list, shard reports, results logs) turned into one report
slurm     --scheduler slurm: the array job script, sbatch, waiting, scancel
"""
