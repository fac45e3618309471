"""Live friction estimation on a CAN bus.

==================  =================================================================
module              holds
==================  =================================================================
``assembler``       decoded frames -> rows of canonical signals, stale signals marked
``runner``          an estimator fed row by row (the online stepping path), live rows
``sinks``           CAN frames, VSS JSON lines (stream, UDP), the Foxglove live view
``loop``            the live loop: source -> rows -> estimator -> sinks, with latency
``replay``          a drive played onto a bus or into a log; buses and logs as sources;
                    a drive replayed into the live loop (tests, the latency benchmark)
==================  =================================================================

Frames are decoded by :class:`roadgrip.io.can.FrameDecoder` (DBC + signal map, faults
dropped and counted). ``roadgrip live`` and ``roadgrip replay`` are the commands.
"""
