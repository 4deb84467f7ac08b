"""The commands of ``video2style``, one module each: ``add_parser(sub)`` adds the command's parser to the
subparsers ``sub`` (its ``run`` as the parsed arguments' ``func``), ``run(args)`` validates and calls the library
functions that tests call too, then reports. :mod:`video2style.cli` is the top parser and the dispatch."""
from video2style.commands import (
    apply,
    batch,
    dataset,
    demo,
    evaluate,
    learn,
    models,
    pose,
    preview,
    skeleton,
    train_classifier,
    train_encoder,
    train_park,
    train_prior,
)

COMMANDS = (demo, dataset, preview, models, skeleton, learn, apply, pose, batch, train_prior, train_encoder, train_park,
            train_classifier, evaluate)  # in --help's order
