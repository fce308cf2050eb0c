"""Metadata formats: how the samples of each ``meta["format"]`` are read, summarised, drawn and
turned into episodes, one module per format, registered by one line in
``datagen.registries.METADATA_FORMATS`` (a plug-in adds its own through the entry point group
``datagen.metadata_formats``).

A format's module defines:

- ``views(meta)``: its labelled views (:class:`datagen.dataset.views.LabelledView`), which every
  frame export (COCO, YOLO, BOP, HDF5, point clouds) reads; the shapes in
  ``datagen.dataset.views`` (cameras of one scene, one camera over time, several cameras over
  time) serve most formats;
- ``summary(metas)``: what ``datagen inspect`` and the dataset card state (JSON values);
- ``distributions(metas)``: name -> values, inspect's histograms (nine at most are drawn);
- ``summary_fields(meta)``: the metadata cut to what ``summary`` reads (the card streams it);
- ``tile(item)``: one loaded sample drawn (BGR uint8), for ``preview`` and inspect's overview;
- ``episodes(meta, dataset, i, manifest)``: the :class:`datagen.exports.episodes.Episode` s the
  sample holds (LeRobot, robomimic), ``[]`` for none;

and may define ``check(meta)`` (raises what its plots cannot take), ``pictures(metas,
title)``: file name -> ``draw(path)`` of inspect's pictures of its own, and ``PARTS``: the
rules that read its parts beyond the images every sample may have
(:class:`datagen.dataset.part_rules.PartRule`: a name pattern and what a matching part adds to
the loaded item; ``datagen.dataset.episode_parts`` has those episodes share). The loader
applies every registered format's rules, so no reader names a family's parts.
"""
