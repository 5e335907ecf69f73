# SPDX-License-Identifier: GPL-3.0-or-later
"""The arap-batch launcher (plain Python 3, standard library only; never imported by Blender).

cli          the command: arguments, the local Blender workers, progress, the run's report (main())
reports      the JSON report: build, write, summary and exit code, merging shards and reruns
runfolder    a sharded run's folder (file list, shard reports, results logs) turned into one report
slurm        --scheduler slurm: the array job script, sbatch, waiting, scancel
build_paths  in the build tree's copy only (written by cmake/ArapBatch.cmake): its staged add-on and Blender

The script addon/arap-batch (copied to the build tree beside this package) and
`python3 -m arap_batch` call cli.main(). The workers run the add-on's
batch_worker.py inside Blender.
"""
