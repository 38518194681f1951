"""Property models: features (λ [1/s], ω [rad/s]) in, properties out.

Regressors (Gaussian process, quadratic, physics-informed GP) for fill height
[mm], sugar concentration [g per 100 g water] and log10 viscosity [cSt]; the
liquid classifier (RBF SVM); container transfer; the JSON model files;
:func:`predict_rows`, a features table's predictions as ``predict`` and ``live`` give them;
and several ring-downs of one bottle combined by their ± (:func:`combine_ring_downs`), with
whether a target can reach its ± at all (:meth:`PropertyModel.reach`).
The estimators are scikit-learn estimators (one target each); see
:mod:`liquidtouch.models.regressors`. This layer imports neither PyAV nor
OpenCV nor the video stages: it trains on feature tables alone
(``tests/test_layers.py`` checks this).
"""

from liquidtouch.models.classifier import LiquidClassifier
from liquidtouch.models.combine import combine_ring_downs
from liquidtouch.models.feature_space import TrainingDomain
from liquidtouch.models.modelfile import load_model, save_model
from liquidtouch.models.physics_prior import PhysicsGPRegressor
from liquidtouch.models.predictions import predict_rows
from liquidtouch.models.property_model import MODEL_KINDS, PropertyModel
from liquidtouch.models.quadratic import QuadraticRegressor
from liquidtouch.models.regressors import GPRegressor
from liquidtouch.models.training import train_classifier, train_regression
from liquidtouch.models.transfer import fit_transfer

__all__ = [
    "MODEL_KINDS",
    "GPRegressor",
    "LiquidClassifier",
    "PhysicsGPRegressor",
    "PropertyModel",
    "QuadraticRegressor",
    "TrainingDomain",
    "combine_ring_downs",
    "fit_transfer",
    "load_model",
    "predict_rows",
    "save_model",
    "train_classifier",
    "train_regression",
]
